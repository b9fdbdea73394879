#include "avatar/facing_cull.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <torch/types.h>

#include "core/error.h"

namespace handscs {

torch::Tensor rest_vertex_normals(const Rig& rig) {
  const auto v = rig.v_template.to(torch::kFloat64);
  const auto f = rig.faces.to(torch::kInt64);
  const auto a = v.index_select(0, f.select(1, 0));
  const auto b = v.index_select(0, f.select(1, 1));
  const auto c = v.index_select(0, f.select(1, 2));
  const auto face_normals = torch::cross(b - a, c - a, 1);  // |.| = twice the face's area
  auto sums = torch::zeros_like(v);
  for (int k = 0; k < 3; ++k) sums.index_add_(0, f.select(1, k), face_normals);
  // Rig files are not checked for their winding: a mesh whose faces turn clockwise seen from
  // outside has a negative signed volume (sum of a . (b x c) / 6), and its normals are turned.
  if ((a * torch::cross(b, c, 1)).sum().item<double>() < 0) sums = -sums;
  const auto length = sums.norm(2, 1, true);
  return torch::where(length > 0, sums / length.clamp_min(1e-300), torch::zeros_like(sums));
}

namespace {

// The smallest cosine between the carried normal and a camera's view ray; -inf when the row is
// kept whatever the threshold (non-finite, or a zero normal or ray).
template <class T>
double smallest_cosine(const T* l, const T* n, const T* x, const FacingCull& cull) {
  // Carried normal l n (row-major 3x3 times the rest normal).
  const double m[3] = {double(l[0]) * n[0] + double(l[1]) * n[1] + double(l[2]) * n[2],
                       double(l[3]) * n[0] + double(l[4]) * n[1] + double(l[5]) * n[2],
                       double(l[6]) * n[0] + double(l[7]) * n[1] + double(l[8]) * n[2]};
  const double m2 = m[0] * m[0] + m[1] * m[1] + m[2] * m[2];
  if (!(std::isfinite(m2) && std::isfinite(double(x[0]) + x[1] + x[2]))) return -INFINITY;
  double smallest = INFINITY;
  for (const auto& c : cull.camera_centres) {
    const double r[3] = {x[0] - c[0], x[1] - c[1], x[2] - c[2]};
    const double r2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
    const double lengths = std::sqrt(m2 * r2);
    if (!(lengths > 0)) return -INFINITY;
    smallest = std::min(smallest, (m[0] * r[0] + m[1] * r[1] + m[2] * r[2]) / lengths);
  }
  return smallest;
}

template <class T>
std::vector<double> smallest_cosines(const torch::Tensor& linear, const torch::Tensor& normals,
                                     const torch::Tensor& means, const FacingCull& cull) {
  const int64_t n = means.size(0);
  const T* l = linear.data_ptr<T>();
  const T* nn = normals.data_ptr<T>();
  const T* x = means.data_ptr<T>();
  std::vector<double> cosines(static_cast<size_t>(n));
  for (int64_t i = 0; i < n; ++i) cosines[i] = smallest_cosine(l + 9 * i, nn + 3 * i, x + 3 * i, cull);
  return cosines;
}

}  // namespace

torch::Tensor facing_rows(const torch::Tensor& linear_in, const torch::Tensor& normals_in,
                          const torch::Tensor& means_in, const FacingCull& cull) {
  require(!cull.camera_centres.empty(), "facing_rows: no camera centre given");
  require(std::isfinite(cull.max_cos) && cull.max_cos >= -1 && cull.max_cos <= 1,
          "facing_rows: max_cos must be in [-1, 1], got " + std::to_string(cull.max_cos));
  const int64_t n = means_in.size(0);
  require(means_in.dim() == 2 && means_in.size(1) == 3 && normals_in.sizes() == means_in.sizes() &&
              linear_in.dim() == 3 && linear_in.size(0) == n && linear_in.size(1) == 3 &&
              linear_in.size(2) == 3,
          "facing_rows: expected linear [N, 3, 3], rest_normals and means [N, 3]");
  torch::NoGradGuard no_grad;
  const auto dtype = means_in.scalar_type();
  require(dtype == torch::kFloat32 || dtype == torch::kFloat64, "facing_rows: float32 or float64 only");
  const auto linear = linear_in.detach().to(dtype).contiguous();
  const auto normals = normals_in.detach().to(dtype).contiguous();
  const auto means = means_in.detach().contiguous();
  const std::vector<double> cosines =
      dtype == torch::kFloat64 ? smallest_cosines<double>(linear, normals, means, cull)
                               : smallest_cosines<float>(linear, normals, means, cull);
  std::vector<int64_t> rows, culled;
  for (int64_t i = 0; i < n; ++i) (cosines[i] <= cull.max_cos ? rows : culled).push_back(i);
  // Rounded up with the culled rows nearest the threshold (smallest cosine, then lowest index).
  const int64_t multiple = std::max<int64_t>(cull.row_multiple, 1);
  const int64_t kept = static_cast<int64_t>(rows.size());
  // At least one multiple: a step that culled every Gaussian would leave L_reg a mean over none.
  const int64_t rounded = std::max<int64_t>((kept + multiple - 1) / multiple, 1) * multiple;
  const int64_t extra = std::min<int64_t>(rounded, n) - kept;
  if (extra > 0) {
    const auto nearer = [&](int64_t a, int64_t b) {
      return cosines[a] < cosines[b] || (cosines[a] == cosines[b] && a < b);
    };
    std::nth_element(culled.begin(), culled.begin() + (extra - 1), culled.end(), nearer);
    rows.insert(rows.end(), culled.begin(), culled.begin() + extra);
    std::sort(rows.begin(), rows.end());
  }
  return torch::tensor(rows, torch::kInt64);
}

}  // namespace handscs
