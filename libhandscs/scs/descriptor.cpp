#include "scs/descriptor.h"

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
