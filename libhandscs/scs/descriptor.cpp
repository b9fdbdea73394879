#include "scs/descriptor.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <ATen/Parallel.h>
#include <torch/types.h>

namespace handscs {

namespace {
// sqrt(max(|a|^2, eps^2)) along the last axis: finite value and gradient everywhere.
torch::Tensor floored_norm(const torch::Tensor& a, double eps) {
  return a.pow(2).sum(-1).clamp_min(eps * eps).sqrt();
}
}  // namespace

torch::Tensor static_descriptor(const torch::Tensor& x, const torch::Tensor& joints,
                                const BoneTopology& topology, double tau, double eps) {
  TORCH_CHECK(x.dim() == 2 && x.size(1) == 3, "static_descriptor: x must be [N, 3], got ",
              x.sizes());
  TORCH_CHECK(joints.dim() == 2 && joints.size(1) == 3, "static_descriptor: joints must be [J, 3], got ",
              joints.sizes());
  const auto u = topology.u.to(joints.device());
  const auto v = topology.v.to(joints.device());
  const auto ju = joints.index_select(0, u);             // [E, 3]
  const auto b = joints.index_select(0, v) - ju;         // [E, 3]
  const auto r = ju.unsqueeze(0) - x.unsqueeze(1);       // [N, E, 3]
  const auto r_sq = r.pow(2).sum(-1);                    // [N, E]
  const auto r_norm = r_sq.clamp_min(eps * eps).sqrt();  // [N, E]
  const auto b_norm = floored_norm(b, eps);              // [E]
  const auto rho = (r * b.unsqueeze(0)).sum(-1) / (r_norm * b_norm.unsqueeze(0));
  const auto d = torch::exp(-r_sq / (tau * tau));
  return d * rho;
}

namespace {
template <class T>
torch::Tensor static_descriptor_loop_typed(const torch::Tensor& x_in, const torch::Tensor& joints_in,
                                           const BoneTopology& topology, double tau, double eps) {
  const auto x = x_in.contiguous();
  const auto joints = joints_in.contiguous();
  const int64_t n = x.size(0), edges = topology.size();
  const T* xp = x.data_ptr<T>();
  const T* jp = joints.data_ptr<T>();
  // Per bone: j_u, b = j_v - j_u and its floored norm, in the dtype and order of the LibTorch form.
  const T eps_sq = static_cast<T>(eps * eps);
  const T tau_sq = static_cast<T>(tau * tau);
  std::vector<T> ju(3 * edges), b(3 * edges), b_norm(edges);
  for (int64_t e = 0; e < edges; ++e) {
    const T* u = jp + 3 * topology.edges[e][0];
    const T* v = jp + 3 * topology.edges[e][1];
    for (int c = 0; c < 3; ++c) {
      ju[3 * e + c] = u[c];
      b[3 * e + c] = v[c] - u[c];
    }
    const T sq = b[3 * e] * b[3 * e] + b[3 * e + 1] * b[3 * e + 1] + b[3 * e + 2] * b[3 * e + 2];
    b_norm[e] = std::sqrt(std::max(sq, eps_sq));
  }
  auto out = torch::empty({n, edges}, x.options());
  T* op = out.data_ptr<T>();
  // 256 Gaussians x 20 bones per task: enough work to wake a thread for.
  at::parallel_for(0, n, 256, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      const T* xi = xp + 3 * i;
      for (int64_t e = 0; e < edges; ++e) {
        const T r0 = ju[3 * e] - xi[0], r1 = ju[3 * e + 1] - xi[1], r2 = ju[3 * e + 2] - xi[2];
        const T r_sq = r0 * r0 + r1 * r1 + r2 * r2;
        const T r_norm = std::sqrt(std::max(r_sq, eps_sq));
        const T rho = (r0 * b[3 * e] + r1 * b[3 * e + 1] + r2 * b[3 * e + 2]) / (r_norm * b_norm[e]);
        op[i * edges + e] = std::exp(-r_sq / tau_sq) * rho;
      }
    }
  });
  return out;
}
}  // namespace

torch::Tensor static_descriptor_loop(const torch::Tensor& x, const torch::Tensor& joints,
                                     const BoneTopology& topology, double tau, double eps) {
  TORCH_CHECK(x.dim() == 2 && x.size(1) == 3, "static_descriptor_loop: x must be [N, 3], got ",
              x.sizes());
  TORCH_CHECK(joints.dim() == 2 && joints.size(1) == 3 && joints.scalar_type() == x.scalar_type(),
              "static_descriptor_loop: joints must be [J, 3] of x's dtype, got ", joints.sizes(), " ",
              joints.scalar_type());
  TORCH_CHECK(x.is_cpu() && joints.is_cpu(), "static_descriptor_loop: CPU tensors only");
  for (const auto& edge : topology.edges)
    TORCH_CHECK(edge[0] >= 0 && edge[1] >= 0 && edge[0] < joints.size(0) && edge[1] < joints.size(0),
                "static_descriptor_loop: bone (", edge[0], ", ", edge[1], ") uses joint ",
                std::max(edge[0], edge[1]), ", but only ", joints.size(0), " joints were given");
  torch::NoGradGuard no_grad;
  if (x.scalar_type() == torch::kDouble)
    return static_descriptor_loop_typed<double>(x, joints, topology, tau, eps);
  TORCH_CHECK(x.scalar_type() == torch::kFloat, "static_descriptor_loop: float or double, got ",
              x.scalar_type());
  return static_descriptor_loop_typed<float>(x, joints, topology, tau, eps);
}

torch::Tensor virtual_descriptor(const torch::Tensor& x, const torch::Tensor& start,
                                 const torch::Tensor& end, double eps) {
  TORCH_CHECK(x.dim() == 2 && x.size(1) == 3, "virtual_descriptor: x must be [N, 3], got ",
              x.sizes());
  TORCH_CHECK(start.dim() == 2 && start.size(1) == 3 && end.sizes() == start.sizes(),
              "virtual_descriptor: start and end must be [M, 3], got ", start.sizes(), " and ",
              end.sizes());
  const auto b = end - start;              // [M, 3]
  const auto b_norm = floored_norm(b, eps);  // [M]
  // r.b = p.b - x.b, as one matmul over all Gaussians.
  const auto rb = (start * b).sum(-1).unsqueeze(0) - x.matmul(b.t());  // [N, M]
  return rb / b_norm.unsqueeze(0);
}

}  // namespace handscs
