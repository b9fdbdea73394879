// 3D Gaussian Splatting PLY files in and out: one `vertex` element per Gaussian with x y z, f_dc_0..2 (degree-0
// spherical-harmonic colour), opacity (logit), scale_0..2 (log), rot_0..3 (quaternion w x y z, not normalised).
// Reads binary_little_endian, binary_big_endian and ascii, any property order and scalar type, extra properties
// (normals, f_rest_*, others) and extra elements; writes binary_little_endian float in the 3DGS reference layout.
#pragma once

#include <string>

#include <torch/types.h>

namespace handscs {

// Raw 3DGS parameters as stored in the file (float32 tensors).
struct GaussianPly {
  torch::Tensor means;           // [N, 3] x y z
  torch::Tensor f_dc;            // [N, 3] f_dc_0..2
  torch::Tensor f_rest;          // [N, K] f_rest_0..K-1, or undefined when the file has none
  torch::Tensor opacity_logits;  // [N] opacity
  torch::Tensor log_scales;      // [N, 3] scale_0..2
  torch::Tensor rotations;       // [N, 4] rot_0..3 = w x y z

  int64_t size() const { return means.defined() ? means.size(0) : 0; }
};

// Degree-0 real spherical harmonic Y_0^0 = 1 / (2 sqrt(pi)): colour = 0.5 + kShC0 * f_dc (the 3DGS convention).
constexpr double kShC0 = 0.28209479177387814;

// Throws handscs::Error naming the file for: unreadable file, not a PLY, unsupported format, truncated header,
// malformed header lines, unknown property types, no vertex element, missing properties (all listed), data
// shorter than the header's counts, data left over after the last element, malformed ascii values.
GaussianPly read_gaussian_ply(const std::string& path);

// Writes atomically (binary_little_endian; normals written as 0 as 3DGS does). Throws handscs::Error on
// inconsistent tensor shapes or when the file cannot be written.
void write_gaussian_ply(const std::string& path, const GaussianPly& gaussians);

// Activated parameters (differentiable torch ops, float32 in, same dtype out).
torch::Tensor ply_colors(const GaussianPly& g);     // [N, 3] 0.5 + kShC0 f_dc (not clamped)
torch::Tensor ply_opacities(const GaussianPly& g);  // [N] sigmoid(opacity logit)
torch::Tensor ply_scales(const GaussianPly& g);     // [N, 3] exp(log scale)

// The inverse: a GaussianPly from activated parameters (opacity clamped to [1e-6, 1 - 1e-6] before the logit).
GaussianPly make_gaussian_ply(const torch::Tensor& means,      // [N, 3]
                              const torch::Tensor& colors,     // [N, 3] RGB
                              const torch::Tensor& opacities,  // [N] in (0, 1)
                              const torch::Tensor& scales,     // [N, 3] > 0
                              const torch::Tensor& rotations); // [N, 4] w x y z

}  // namespace handscs
