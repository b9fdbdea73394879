// Eigen-decomposition of a small symmetric matrix (n <= 8) by cyclic Jacobi rotations, in plain
// doubles: for the 4x4 problems of rigid alignment (Horn's quaternion) and triangulation (DLT),
// which run inside parallel loops where no LibTorch op may run.
#pragma once

#include <vector>

namespace handscs {

// a: n x n row-major symmetric. Returns eigenvalues ascending; vectors[i * n + k] is component k
// of the eigenvector of values[i] (unit length).
void symmetric_eigen(const double* a, int n, std::vector<double>& values, std::vector<double>& vectors);

}  // namespace handscs
