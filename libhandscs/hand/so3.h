// Rotations in plain doubles (row-major 3x3) for the loops that skin or fit one hand without
// LibTorch: the exponential map (Rodrigues), its right Jacobian and the logarithm.
//   R(v) = I + a K + b K^2,  K = [v]_x, t = |v|, a = sin t / t, b = (1 - cos t) / t^2
//   R(v + dv) = R(v) exp([J_r(v) dv]_x) to first order,
//   J_r(v) = I - b K + c K^2, c = (t - sin t) / t^3
#pragma once

#include <array>

#include "core/vec3.h"

namespace handscs {

using Mat3 = std::array<double, 9>;  // row-major

// Exponential map of an axis-angle vector; Taylor series below t^2 = 1e-4 (the same formulas as
// hand/lbs.cpp's rodrigues in double), so value and derivatives are finite at zero.
Mat3 rodrigues_one(const double* axis_angle);

// Right Jacobian of the exponential map at v (finite at zero: J_r(0) = I).
Mat3 right_jacobian(const double* axis_angle);

// Axis-angle of a rotation matrix with angle in [0, pi]; accurate near 0 and near pi.
Vec3 rotation_log(const Mat3& R);

Mat3 mat_mul(const Mat3& a, const Mat3& b);
Mat3 mat_transpose(const Mat3& a);
Vec3 mat_vec(const Mat3& a, const Vec3& v);

}  // namespace handscs
