#include "scs/descriptor.h"

#include <algorithm>
#include <cmath>
#include <type_traits>
#include <vector>

#include <ATen/Parallel.h>
#include <torch/csrc/autograd/custom_function.h>
#include <torch/types.h>

#include "core/lanes.h"

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

// Per bone: j_u, b = j_v - j_u, |b|^2 and the floored norm, in the dtype and order of the LibTorch
// form.
template <class T>
struct BoneArrays {
  std::vector<T> ju, b, b_sq, b_norm;
  BoneArrays(const T* jp, const BoneTopology& topology, T eps_sq) {
    const int64_t edges = topology.size();
    ju.resize(3 * edges);
    b.resize(3 * edges);
    b_sq.resize(edges);
    b_norm.resize(edges);
    for (int64_t e = 0; e < edges; ++e) {
      const T* u = jp + 3 * topology.edges[e][0];
      const T* v = jp + 3 * topology.edges[e][1];
      for (int c = 0; c < 3; ++c) {
        ju[3 * e + c] = u[c];
        b[3 * e + c] = v[c] - u[c];
      }
      b_sq[e] = b[3 * e] * b[3 * e] + b[3 * e + 1] * b[3 * e + 1] + b[3 * e + 2] * b[3 * e + 2];
      b_norm[e] = std::sqrt(std::max(b_sq[e], eps_sq));
    }
  }
};

// Gaussians per parallel task: 256 Gaussians x 20 bones is enough work to wake a thread for; the
// joints' gradient is summed per task in task order, so it does not depend on the thread count.
constexpr int64_t kGaussiansPerTask = 256;

// What the loops read: the Gaussians' x [N, 3] (contiguous), the bones, and the constants.
template <class E>
struct DescriptorArgs {
  const E* x;
  const E *ju, *b, *b_sq, *b_norm;  // BoneArrays
  int64_t edges;
  E eps_sq, tau_sq;
};

// The loops' view of x [N, 3] (contiguous) and of the bones.
template <class T>
DescriptorArgs<T> descriptor_args(const torch::Tensor& x, const BoneArrays<T>& bones, T eps_sq, T tau_sq) {
  return {x.data_ptr<T>(),     bones.ju.data(), bones.b.data(), bones.b_sq.data(), bones.b_norm.data(),
          static_cast<int64_t>(bones.b_norm.size()), eps_sq, tau_sq};
}

// One copy of the loops per instruction set (no FMA contraction in this file: CMakeLists), so each
// gives the other's values bit for bit.
#define HANDSCS_KERNELS "scs/static_descriptor_lanes.inc"
#include "core/generic_and_avx512.inc"

template <class T>
torch::Tensor static_descriptor_loop_typed(const torch::Tensor& x_in, const torch::Tensor& joints_in,
                                           const BoneTopology& topology, double tau, double eps) {
  const auto x = x_in.contiguous();
  const auto joints = joints_in.contiguous();
  const int64_t n = x.size(0), edges = topology.size();
  const T eps_sq = static_cast<T>(eps * eps);
  const T tau_sq = static_cast<T>(tau * tau);
  const BoneArrays<T> bones(joints.data_ptr<T>(), topology, eps_sq);
  const auto args = descriptor_args(x, bones, eps_sq, tau_sq);
  auto out = torch::empty({n, edges}, x.options());
  T* op = out.data_ptr<T>();
  const bool simd = lanes16_active<T>();
  at::parallel_for(0, n, kGaussiansPerTask, [&](int64_t begin, int64_t end) {
    if constexpr (std::is_same_v<T, float>) {
      if (simd) return avx512::static_descriptor_rows<Lanes16>(args, op, begin, end);
    }
    generic::static_descriptor_rows<T>(args, op, begin, end);
  });
  return out;
}

// The backward of static_descriptor_loop_typed given grad [N, E]: d/dx [N, 3] and d/djoints [J, 3].
// With r = j_u - x, P = d rho, d = exp(-|r|^2 / tau^2), rho = r.b / (|r|_f |b|_f) (norms floored at
// eps, constant below it as clamp_min makes them):
//   dP/dr = d (b / (|r|_f |b|_f) - rho r / |r|_f^2 [|r|^2 >= eps^2]) - 2 P r / tau^2,
//   dP/db = d (r / (|r|_f |b|_f) - rho b / |b|_f^2 [|b|^2 >= eps^2]),
// and x receives -dP/dr, j_u dP/dr - dP/db, j_v dP/db. kJoints false: d/djoints is neither computed
// nor returned (undefined), the usual case of a fixed pose.
template <class T, bool kJoints>
std::vector<torch::Tensor> static_descriptor_backward_typed(const torch::Tensor& x_in, const torch::Tensor& joints_in,
                                                            const torch::Tensor& grad_in, const BoneTopology& topology,
                                                            double tau, double eps) {
  const auto x = x_in.contiguous(), joints = joints_in.contiguous(), grad = grad_in.contiguous();
  const int64_t n = x.size(0), edges = topology.size();
  const T* gp = grad.data_ptr<T>();
  const T eps_sq = static_cast<T>(eps * eps);
  const T tau_sq = static_cast<T>(tau * tau);
  const BoneArrays<T> bones(joints.data_ptr<T>(), topology, eps_sq);
  const auto args = descriptor_args(x, bones, eps_sq, tau_sq);
  auto grad_x = torch::empty({n, 3}, x.options());
  T* gxp = grad_x.data_ptr<T>();
  const int64_t tasks = (n + kGaussiansPerTask - 1) / kGaussiansPerTask;
  // Per task and bone: the sums of dP/dr and dP/db (weighted by the incoming gradient).
  const size_t sums = kJoints ? size_t(tasks * edges * 3) : 0;
  std::vector<T> sum_r(sums, T(0)), sum_b(sums, T(0));
  const bool simd = lanes16_active<T>();
  at::parallel_for(0, tasks, 1, [&](int64_t first, int64_t last) {
    for (int64_t task = first; task < last; ++task) {
      T* sr = kJoints ? sum_r.data() + task * edges * 3 : nullptr;
      T* sb = kJoints ? sum_b.data() + task * edges * 3 : nullptr;
      const int64_t begin = task * kGaussiansPerTask, end = std::min(n, begin + kGaussiansPerTask);
      if constexpr (std::is_same_v<T, float>) {
        if (simd) {
          avx512::static_descriptor_backward_rows<Lanes16, T, kJoints>(args, gp, gxp, sr, sb, begin, end);
          continue;
        }
      }
      generic::static_descriptor_backward_rows<T, T, kJoints>(args, gp, gxp, sr, sb, begin, end);
    }
  });
  if constexpr (!kJoints) return {grad_x, torch::Tensor()};
  auto grad_joints = torch::zeros(joints.sizes(), joints.options());
  T* gjp = grad_joints.data_ptr<T>();
  for (int64_t task = 0; task < tasks; ++task)
    for (int64_t e = 0; e < edges; ++e) {
      T* gu = gjp + 3 * topology.edges[e][0];
      T* gv = gjp + 3 * topology.edges[e][1];
      for (int c = 0; c < 3; ++c) {
        const T dr = sum_r[(task * edges + e) * 3 + c], db = sum_b[(task * edges + e) * 3 + c];
        gu[c] += dr - db;
        gv[c] += db;
      }
    }
  return {grad_x, grad_joints};
}

using torch::autograd::AutogradContext;
using torch::autograd::variable_list;

struct StaticDescriptorFunction : public torch::autograd::Function<StaticDescriptorFunction> {
  static torch::Tensor forward(AutogradContext* ctx, const torch::Tensor& x, const torch::Tensor& joints,
                               const BoneTopology& topology, double tau, double eps) {
    ctx->save_for_backward({x, joints});
    ctx->saved_data["tau"] = tau;
    ctx->saved_data["eps"] = eps;
    std::vector<int64_t> edges;
    for (const auto& edge : topology.edges) edges.insert(edges.end(), {edge[0], edge[1]});
    ctx->saved_data["edges"] = edges;
    return x.scalar_type() == torch::kDouble ? static_descriptor_loop_typed<double>(x, joints, topology, tau, eps)
                                             : static_descriptor_loop_typed<float>(x, joints, topology, tau, eps);
  }

  static variable_list backward(AutogradContext* ctx, variable_list grads) {
    const auto saved = ctx->get_saved_variables();
    BoneTopology topology;  // the bones only: the loops read nothing else
    const auto edges = ctx->saved_data["edges"].toIntVector();
    for (size_t k = 0; k + 1 < edges.size(); k += 2) topology.edges.push_back({int(edges[k]), int(edges[k + 1])});
    const double tau = ctx->saved_data["tau"].toDouble(), eps = ctx->saved_data["eps"].toDouble();
    // The joints usually come from a fixed pose; their gradient is only computed when asked for.
    const bool joints = ctx->needs_input_grad(1), is_double = saved[0].scalar_type() == torch::kDouble;
    const auto& x = saved[0];
    const auto& j = saved[1];
    auto g = is_double ? (joints ? static_descriptor_backward_typed<double, true>(x, j, grads[0], topology, tau, eps)
                                 : static_descriptor_backward_typed<double, false>(x, j, grads[0], topology, tau, eps))
                       : (joints ? static_descriptor_backward_typed<float, true>(x, j, grads[0], topology, tau, eps)
                                 : static_descriptor_backward_typed<float, false>(x, j, grads[0], topology, tau, eps));
    return {g[0], g[1], torch::Tensor(), torch::Tensor(), torch::Tensor()};
  }
};

}  // namespace

torch::Tensor static_descriptor_loop(const torch::Tensor& x, const torch::Tensor& joints,
                                     const BoneTopology& topology, double tau, double eps) {
  TORCH_CHECK(x.dim() == 2 && x.size(1) == 3, "static_descriptor_loop: x must be [N, 3], got ",
              x.sizes());
  TORCH_CHECK(joints.dim() == 2 && joints.size(1) == 3 && joints.scalar_type() == x.scalar_type(),
              "static_descriptor_loop: joints must be [J, 3] of x's dtype, got ", joints.sizes(), " ",
              joints.scalar_type());
  TORCH_CHECK(x.is_cpu() && joints.is_cpu(), "static_descriptor_loop: CPU tensors only");
  TORCH_CHECK(x.scalar_type() == torch::kFloat || x.scalar_type() == torch::kDouble,
              "static_descriptor_loop: float or double, got ", x.scalar_type());
  for (const auto& edge : topology.edges)
    TORCH_CHECK(edge[0] >= 0 && edge[1] >= 0 && edge[0] < joints.size(0) && edge[1] < joints.size(0),
                "static_descriptor_loop: bone (", edge[0], ", ", edge[1], ") uses joint ",
                std::max(edge[0], edge[1]), ", but only ", joints.size(0), " joints were given");
  if (torch::GradMode::is_enabled() && (x.requires_grad() || joints.requires_grad()))
    return StaticDescriptorFunction::apply(x, joints, topology, tau, eps);
  torch::NoGradGuard no_grad;
  if (x.scalar_type() == torch::kDouble)
    return static_descriptor_loop_typed<double>(x, joints, topology, tau, eps);
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
