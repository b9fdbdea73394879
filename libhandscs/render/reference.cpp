#include "render/reference.h"

#include <torch/types.h>

#include "render/composite.h"
#include "render/raster_frame.h"

namespace handscs {

namespace {

// Projection in tensor ops: returns (mu2D [n, 2] image pixels, conic [n, 3] (a, b, c), z [n], A, C, det [n]).
struct ReferenceProjection {
  torch::Tensor mean2d, conic, z, A, C, det;
};

ReferenceProjection project(const RasterFrame& f, const torch::Tensor& means, const torch::Tensor& covs,
                            const torch::Tensor& probe) {
  const auto opts = means.options();
  const auto R = torch::tensor(std::vector<double>(f.R.begin(), f.R.end()), opts.dtype(torch::kFloat64))
                     .view({3, 3})
                     .to(means.scalar_type());
  const auto t = torch::tensor(std::vector<double>(f.t.begin(), f.t.end()), opts.dtype(torch::kFloat64))
                     .to(means.scalar_type());
  const auto p = torch::matmul(means, R.t()) + t;
  const auto x = p.select(1, 0), y = p.select(1, 1), z = p.select(1, 2);
  const auto u = x / z, v = y / z;
  const auto uc = u.clamp(f.u_lo, f.u_hi), vc = v.clamp(f.v_lo, f.v_hi);
  const auto j00 = f.fx / z, j02 = -f.fx * uc / z, j11 = f.fy / z, j12 = -f.fy * vc / z;
  const auto row0 = j00.unsqueeze(1) * R[0] + j02.unsqueeze(1) * R[2];  // [n, 3] first row of J R
  const auto row1 = j11.unsqueeze(1) * R[1] + j12.unsqueeze(1) * R[2];
  const auto c = covs;
  const auto sigma = torch::stack({c.select(1, 0), c.select(1, 1), c.select(1, 2), c.select(1, 1), c.select(1, 3),
                                   c.select(1, 4), c.select(1, 2), c.select(1, 4), c.select(1, 5)},
                                  1)
                         .view({-1, 3, 3});
  const auto s_row0 = torch::matmul(sigma, row0.unsqueeze(2)).squeeze(2);
  const auto s_row1 = torch::matmul(sigma, row1.unsqueeze(2)).squeeze(2);
  ReferenceProjection out;
  const auto a0 = (row0 * s_row0).sum(1), c0 = (row1 * s_row1).sum(1);
  out.A = a0 + 0.3;
  const auto B = (row0 * s_row1).sum(1);
  out.C = c0 + 0.3;
  // det(Sigma2D) by Cauchy-Binet, as the kernel (stable for ill-conditioned covariances): see projection.cpp.
  const int pairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  auto S = [&](int i, int k) { return sigma.select(1, i).select(1, k); };
  std::vector<torch::Tensor> mu;
  for (const auto& p : pairs)
    mu.push_back(row0.select(1, p[0]) * row1.select(1, p[1]) - row0.select(1, p[1]) * row1.select(1, p[0]));
  auto det0 = torch::zeros_like(a0);
  for (int p = 0; p < 3; ++p)
    for (int q = 0; q < 3; ++q) {
      const int i = pairs[p][0], j = pairs[p][1], k = pairs[q][0], l = pairs[q][1];
      det0 = det0 + mu[p] * (S(i, k) * S(j, l) - S(i, l) * S(j, k)) * mu[q];
    }
  out.det = det0 + 0.3 * (a0 + c0) + 0.09;
  out.conic = torch::stack({out.C / out.det, -B / out.det, out.A / out.det}, 1);
  auto mean2d = torch::stack({f.fx * u + f.cx, f.fy * v + f.cy}, 1);
  if (probe.defined()) mean2d = mean2d + probe;
  out.mean2d = mean2d;
  out.z = z;
  return out;
}

}  // namespace

RasterOutput rasterize_gaussians_reference(const torch::Tensor& means, const torch::Tensor& covariances,
                                           const torch::Tensor& colors, const torch::Tensor& opacities,
                                           const Camera& camera, const RasterSettings& settings,
                                           const torch::Tensor& means2d_probe) {
  const RasterFrame f = make_raster_frame(camera, settings);
  const int64_t n = means.size(0);
  const auto opts = means.options();
  const auto opacity = opacities.reshape({n});
  const bool has_probe = means2d_probe.defined();

  // Culling decisions and the depth order (no gradient), in double like the kernel's projection; the sort key
  // is the kernel's camera z, same operations and order, cast to the input dtype (ties: lower index first).
  torch::Tensor valid, depth_key;
  {
    torch::NoGradGuard no_grad;
    const auto md = means.to(torch::kFloat64), cd = covariances.to(torch::kFloat64);
    valid = torch::isfinite(md).all(1) & torch::isfinite(cd).all(1) & torch::isfinite(colors).all(1) &
            torch::isfinite(opacity) & (opacity >= kAlphaSkip);
    if (has_probe) valid = valid & torch::isfinite(means2d_probe).all(1);
    const auto safe_means = torch::where(valid.unsqueeze(1), md, torch::zeros_like(md));
    const auto safe_covs = torch::where(valid.unsqueeze(1), cd, torch::zeros_like(cd));
    const auto pd = project(f, safe_means, safe_covs,
                            has_probe ? torch::where(valid.unsqueeze(1), means2d_probe, torch::zeros_like(means2d_probe))
                                            .to(torch::kFloat64)
                                      : torch::Tensor());
    depth_key = (((md.select(1, 0) * f.R[6] + md.select(1, 1) * f.R[7]) + md.select(1, 2) * f.R[8]) + f.t[2])
                    .to(means.scalar_type());
    valid = valid & (pd.z > f.near_plane) & (pd.z <= f.far_plane) & (pd.A > 0) & (pd.C > 0) & (pd.det > 0) &
            torch::isfinite(pd.det) & torch::isfinite(1.0 / pd.det) & torch::isfinite(pd.mean2d).all(1);
  }

  // Culled Gaussians are replaced by a harmless one (in front of the camera, small) so no NaN or Inf can reach
  // the autograd graph; their alpha is zeroed below, so their inputs get exactly zero gradient.
  std::array<double, 3> safe_point;
  for (int i = 0; i < 3; ++i)
    safe_point[i] = f.R[0 + i] * (0 - f.t[0]) + f.R[3 + i] * (0 - f.t[1]) + f.R[6 + i] * (1 - f.t[2]);
  const auto keep_row = valid.unsqueeze(1);
  const auto m = torch::where(keep_row, means,
                              torch::tensor(std::vector<double>(safe_point.begin(), safe_point.end()), opts));
  const auto cv = torch::where(keep_row, covariances, torch::tensor({1e-4, 0.0, 0.0, 1e-4, 0.0, 1e-4}, opts));
  const auto col = torch::where(keep_row, colors, torch::full({3}, 0.5, opts)).clamp(0, 1);
  const auto op = torch::where(valid, opacity, torch::full({}, 0.5, opts));
  const auto probe =
      has_probe ? torch::where(keep_row, means2d_probe, torch::zeros({2}, opts)) : torch::Tensor();
  const auto proj = project(f, m, cv, probe);

  // Pixel centres of the region, image coordinates.
  const auto xs = torch::arange(f.width, opts) + (f.x0 + 0.5);
  const auto ys = torch::arange(f.height, opts) + (f.y0 + 0.5);
  const auto grid = torch::meshgrid({ys, xs}, "ij");
  const auto px = grid[1].reshape({-1, 1}), py = grid[0].reshape({-1, 1});  // [P, 1]
  const auto dx = px - proj.mean2d.select(1, 0).unsqueeze(0);                // [P, n]
  const auto dy = py - proj.mean2d.select(1, 1).unsqueeze(0);
  const auto a = proj.conic.select(1, 0), b = proj.conic.select(1, 1), c = proj.conic.select(1, 2);
  const auto power = -0.5 * (a * dx * dx + c * dy * dy) - b * dx * dy;
  auto alpha = (op * torch::exp(power)).clamp_max(kAlphaCap);
  torch::Tensor visible;
  {
    torch::NoGradGuard no_grad;
    visible = (alpha >= kAlphaSkip) & valid.unsqueeze(0);
  }
  alpha = torch::where(visible, alpha, torch::zeros({}, opts));
  const int64_t num_pixels = f.num_pixels();
  torch::Tensor rgb, alpha_out, depth_acc;
  const auto bg = torch::tensor(std::vector<double>(f.background.begin(), f.background.end()), opts);
  if (n == 0) {
    // Keep the (empty) inputs in the graph so backward works and gives empty gradients.
    auto zero = (means.sum() + covariances.sum() + colors.sum() + opacity.sum()) * 0;
    if (has_probe) zero = zero + means2d_probe.sum() * 0;
    rgb = bg.expand({num_pixels, 3}) + zero;
    alpha_out = torch::zeros({num_pixels}, opts) + zero;
    depth_acc = torch::zeros({num_pixels}, opts) + zero;
  } else {
    const auto order = std::get<1>(torch::sort(depth_key, /*stable=*/true, /*dim=*/0, /*descending=*/false));
    const auto alpha_sorted = alpha.index_select(1, order);
    torch::Tensor keep;
    {
      torch::NoGradGuard no_grad;
      keep = torch::cumprod(1 - alpha_sorted, 1) >= kMinTransmittance;
    }
    const auto alpha_kept = torch::where(keep, alpha_sorted, torch::zeros({}, opts));
    const auto t_incl = torch::cumprod(1 - alpha_kept, 1);
    const auto t_excl = torch::cat({torch::ones({num_pixels, 1}, opts), t_incl.narrow(1, 0, n - 1)}, 1);
    const auto w = alpha_kept * t_excl;
    const auto t_final = t_incl.select(1, n - 1);
    rgb = torch::matmul(w, col.index_select(0, order)) + t_final.unsqueeze(1) * bg;
    alpha_out = 1 - t_final;
    depth_acc = torch::matmul(w, proj.z.index_select(0, order));
  }
  RasterOutput out;
  out.rgb = rgb.reshape({f.height, f.width, 3});
  out.alpha = alpha_out.reshape({f.height, f.width});
  if (settings.compute_depth)
    out.depth = depth_acc.reshape({f.height, f.width}) / out.alpha.clamp_min(0.5 * kAlphaSkip);
  return out;
}

}  // namespace handscs
