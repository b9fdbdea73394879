#include "avatar/covariance_chain.h"

#include <cmath>
#include <tuple>
#include <type_traits>
#include <vector>

#include <ATen/Parallel.h>
#include <torch/csrc/autograd/custom_function.h>
#include <torch/types.h>

#include "avatar/avatar.h"
#include "core/lanes.h"
#include "render/rotation.h"

namespace handscs {

namespace {

// The chain's inputs and outputs as pointers and strides (element units). rotations [N, 4] and
// log_scales [N, 3] are contiguous; the raw SPD values and L may be strided.
template <class E>
struct ChainArgs {
  const E* rotations;
  const E* log_scales;
  const E* geometry;  // [N, 7] raw values of dSigma
  int64_t g_row, g_col;
  const E* fusion;  // [N, 7] raw values of dSigma^f
  int64_t f_row, f_col;
  const E* linear;  // [N, 3, 3] L
  int64_t l_row, l_i, l_j;
};

template <class E>
struct ChainOutputs {  // contiguous
  E* dsigma;       // [N, 3, 3]
  E* dsigma_f;     // [N, 3, 3]
  E* canonical;    // [N, 3, 3]
  E* posed_upper;  // [N, 6]
};

// Incoming gradients (read) and outgoing ones (written), contiguous.
template <class E>
struct ChainGrads {
  const E* dsigma;     // [N, 3, 3]
  const E* dsigma_f;   // [N, 3, 3]
  const E* canonical;  // [N, 3, 3]
  const E* upper;      // [N, 6]
  E* rotations;        // [N, 4]
  E* log_scales;       // [N, 3]
  E* geometry;         // [N, 7]
  E* fusion;           // [N, 7]
  E* linear;           // [N, 3, 3]
};

// One copy of the per-Gaussian arithmetic per instruction set (no FMA contraction in this file:
// CMakeLists), so each gives the other's values bit for bit.
#define HANDSCS_KERNELS "avatar/covariance_chain_lanes.inc"
#include "core/generic_and_avx512.inc"

// Gaussians per parallel task at least: 256 Gaussians' chains (~40 us, more in the backward) are
// more work than a task's start costs, and 10k give each thread thousands.
constexpr int64_t kGrain = 256;

template <class T>
ChainArgs<T> chain_args(const torch::Tensor& rotations, const torch::Tensor& log_scales,
                        const torch::Tensor& geometry_raw, const torch::Tensor& fusion_raw,
                        const torch::Tensor& linear) {
  return {rotations.data_ptr<T>(),  log_scales.data_ptr<T>(),
          geometry_raw.data_ptr<T>(), geometry_raw.stride(0), geometry_raw.stride(1),
          fusion_raw.data_ptr<T>(),   fusion_raw.stride(0),   fusion_raw.stride(1),
          linear.data_ptr<T>(),       linear.stride(0),       linear.stride(1),
          linear.stride(2)};
}

template <class T>
CovarianceChain run(const torch::Tensor& rotations, const torch::Tensor& log_scales,
                    const torch::Tensor& geometry_raw, const torch::Tensor& fusion_raw,
                    const torch::Tensor& linear) {
  const int64_t n = rotations.size(0);
  const auto opts = rotations.options();
  CovarianceChain out{torch::empty({n, 3, 3}, opts), torch::empty({n, 3, 3}, opts),
                      torch::empty({n, 3, 3}, opts), torch::empty({n, 6}, opts)};
  const auto q = rotations.contiguous(), s = log_scales.contiguous();
  const auto args = chain_args<T>(q, s, geometry_raw, fusion_raw, linear);
  const ChainOutputs<T> outputs{out.dsigma.data_ptr<T>(), out.dsigma_f.data_ptr<T>(), out.canonical.data_ptr<T>(),
                                out.posed_upper.data_ptr<T>()};
  const bool simd = lanes16_active<T>();
  at::parallel_for(0, n, kGrain, [&](int64_t begin, int64_t end) {
    if constexpr (std::is_same_v<T, float>) {
      if (simd) return avx512::chain_forward<Lanes16>(args, outputs, begin, end);
    }
    generic::chain_forward<T>(args, outputs, begin, end);
  });
  return out;
}

// The chain's backward, the forward recomputed per Gaussian. Incoming gradients: g_dsigma,
// g_dsigma_f, g_canonical [N, 3, 3], g_upper [N, 6]. Outgoing: rotations [N, 4], log_scales
// [N, 3], geometry_raw and fusion_raw [N, 7], linear [N, 3, 3] (contiguous).
template <class T>
std::vector<torch::Tensor> run_backward(const torch::Tensor& rotations, const torch::Tensor& log_scales,
                                        const torch::Tensor& geometry_raw, const torch::Tensor& fusion_raw,
                                        const torch::Tensor& linear, const torch::Tensor& g_dsigma_in,
                                        const torch::Tensor& g_dsigma_f_in, const torch::Tensor& g_canonical_in,
                                        const torch::Tensor& g_upper_in) {
  const int64_t n = rotations.size(0);
  const auto opts = rotations.options();
  auto g_rotations = torch::empty({n, 4}, opts), g_log_scales = torch::empty({n, 3}, opts);
  auto g_geometry = torch::empty({n, 7}, opts), g_fusion = torch::empty({n, 7}, opts);
  auto g_linear = torch::empty({n, 3, 3}, opts);
  const auto q = rotations.contiguous(), s = log_scales.contiguous();
  const auto args = chain_args<T>(q, s, geometry_raw, fusion_raw, linear);
  const auto gds = g_dsigma_in.contiguous(), gdf = g_dsigma_f_in.contiguous();
  const auto gc = g_canonical_in.contiguous(), gu = g_upper_in.contiguous();
  const ChainGrads<T> grads{gds.data_ptr<T>(),         gdf.data_ptr<T>(),          gc.data_ptr<T>(),
                            gu.data_ptr<T>(),          g_rotations.data_ptr<T>(),  g_log_scales.data_ptr<T>(),
                            g_geometry.data_ptr<T>(),  g_fusion.data_ptr<T>(),     g_linear.data_ptr<T>()};
  const bool simd = lanes16_active<T>();
  at::parallel_for(0, n, kGrain, [&](int64_t begin, int64_t end) {
    if constexpr (std::is_same_v<T, float>) {
      if (simd) return avx512::chain_backward<Lanes16>(args, grads, begin, end);
    }
    generic::chain_backward<T>(args, grads, begin, end);
  });
  return {g_rotations, g_log_scales, g_geometry, g_fusion, g_linear};
}

using torch::autograd::AutogradContext;
using torch::autograd::variable_list;

struct CovarianceChainFunction : public torch::autograd::Function<CovarianceChainFunction> {
  static variable_list forward(AutogradContext* ctx, const torch::Tensor& rotations, const torch::Tensor& log_scales,
                               const torch::Tensor& geometry_raw, const torch::Tensor& fusion_raw,
                               const torch::Tensor& linear) {
    ctx->save_for_backward({rotations, log_scales, geometry_raw, fusion_raw, linear});
    const auto out = rotations.scalar_type() == torch::kDouble
                         ? run<double>(rotations, log_scales, geometry_raw, fusion_raw, linear)
                         : run<float>(rotations, log_scales, geometry_raw, fusion_raw, linear);
    return {out.dsigma, out.dsigma_f, out.canonical, out.posed_upper};
  }

  static variable_list backward(AutogradContext* ctx, variable_list grads) {
    const auto saved = ctx->get_saved_variables();
    const auto& rotations = saved[0];
    const auto args = std::make_tuple(saved[0], saved[1], saved[2], saved[3], saved[4], grads[0], grads[1],
                                      grads[2], grads[3]);
    return rotations.scalar_type() == torch::kDouble ? std::apply(run_backward<double>, args)
                                                     : std::apply(run_backward<float>, args);
  }
};

}  // namespace

CovarianceChain covariance_chain_ops(const torch::Tensor& rotations, const torch::Tensor& log_scales,
                                     const torch::Tensor& dsigma, const torch::Tensor& dsigma_f,
                                     const torch::Tensor& linear) {
  const auto rot = quaternion_to_matrix(rotations);
  const auto scaled = rot * torch::exp(log_scales).unsqueeze(1);
  const auto sigma = scaled.matmul(scaled.transpose(1, 2));  // R S S R^T
  const auto a = dsigma_f.matmul(dsigma);                    // A = dSigma^f dSigma
  CovarianceChain out;
  out.dsigma = dsigma;
  out.dsigma_f = dsigma_f;
  out.canonical = a.matmul(sigma).matmul(a.transpose(1, 2));  // A Sigma A^T
  out.posed_upper = symmetric_upper(linear.matmul(out.canonical).matmul(linear.transpose(1, 2)));
  return out;
}

CovarianceChain covariance_chain(const torch::Tensor& rotations, const torch::Tensor& log_scales,
                                 const torch::Tensor& geometry_raw, const torch::Tensor& fusion_raw,
                                 const torch::Tensor& linear) {
  const int64_t n = rotations.dim() == 2 ? rotations.size(0) : -1;
  const auto rows_of = [n](const torch::Tensor& t, std::initializer_list<int64_t> tail) {
    if (t.dim() != int64_t(tail.size()) + 1 || t.size(0) != n) return false;
    int64_t d = 1;
    for (const int64_t size : tail)
      if (t.size(d++) != size) return false;
    return true;
  };
  TORCH_CHECK(rows_of(rotations, {4}), "covariance_chain: rotations must be [N, 4], got ", rotations.sizes());
  TORCH_CHECK(rows_of(log_scales, {3}), "covariance_chain: log_scales must be [", n, ", 3], got ",
              log_scales.sizes());
  TORCH_CHECK(rows_of(geometry_raw, {7}), "covariance_chain: geometry_raw must be [", n, ", 7], got ",
              geometry_raw.sizes());
  TORCH_CHECK(rows_of(fusion_raw, {7}), "covariance_chain: fusion_raw must be [", n, ", 7], got ",
              fusion_raw.sizes());
  TORCH_CHECK(rows_of(linear, {3, 3}), "covariance_chain: linear must be [", n, ", 3, 3], got ", linear.sizes());
  const auto dtype = rotations.scalar_type();
  TORCH_CHECK((dtype == torch::kFloat || dtype == torch::kDouble) && log_scales.scalar_type() == dtype &&
                  geometry_raw.scalar_type() == dtype && fusion_raw.scalar_type() == dtype &&
                  linear.scalar_type() == dtype,
              "covariance_chain: one dtype, float or double, for every input; got rotations ", dtype,
              ", log_scales ", log_scales.scalar_type(), ", geometry_raw ", geometry_raw.scalar_type(),
              ", fusion_raw ", fusion_raw.scalar_type(), ", linear ", linear.scalar_type());
  TORCH_CHECK(rotations.is_cpu() && log_scales.is_cpu() && geometry_raw.is_cpu() && fusion_raw.is_cpu() &&
                  linear.is_cpu(),
              "covariance_chain: CPU tensors only");
  const bool graph = torch::GradMode::is_enabled() &&
                     (rotations.requires_grad() || log_scales.requires_grad() || geometry_raw.requires_grad() ||
                      fusion_raw.requires_grad() || linear.requires_grad());
  if (graph) {
    const auto out = CovarianceChainFunction::apply(rotations, log_scales, geometry_raw, fusion_raw, linear);
    return {out[0], out[1], out[2], out[3]};
  }
  torch::NoGradGuard no_grad;
  if (rotations.scalar_type() == torch::kDouble)
    return run<double>(rotations, log_scales, geometry_raw, fusion_raw, linear);
  return run<float>(rotations, log_scales, geometry_raw, fusion_raw, linear);
}

}  // namespace handscs
