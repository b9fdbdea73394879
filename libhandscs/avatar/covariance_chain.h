// The avatar's per-Gaussian 3x3 chain, in one pass over the Gaussians:
//   dSigma = R(q_g) diag(exp(s_g)) R(q_g)^T,  dSigma^f likewise (decoders/spd_from_raw),
//   Sigma = R(q) diag(exp(s))^2 R(q)^T,  Sigma' = A Sigma A^T with A = dSigma^f dSigma,
//   posed = L Sigma' L^T (upper triangle), L the blend transform's 3x3 part.
// The same arithmetic as the LibTorch ops of covariance_chain_ops (quaternions normalised with the
// 1e-24 floor of render/rotation.h), without their ~150 small kernels and temporaries. Under
// autograd it is one op whose backward is written out here (the forward recomputed per Gaussian):
// in training the ops' forward + backward took 7.5 ms at 10k Gaussians. Equal to the ops to
// rounding (tests/avatar/test_covariance_chain.cpp, in double, values and gradients). On AVX-512
// CPUs float runs 16 Gaussians per pass (avatar/covariance_chain_lanes.inc, core/lanes.h), with the
// plain loop's values and gradients bit for bit (tested): 2.6 -> 0.8 ms forward + backward at 10k.
#pragma once

#include <torch/types.h>

namespace handscs {

struct CovarianceChain {
  torch::Tensor dsigma, dsigma_f;  // [N, 3, 3]
  torch::Tensor canonical;         // [N, 3, 3] Sigma'
  torch::Tensor posed_upper;       // [N, 6] upper triangle of L Sigma' L^T
};

// rotations [N, 4] (w, x, y, z), log_scales [N, 3], geometry_raw and fusion_raw [N, 7] (3
// log-scales, 4 quaternion-delta values; rows may be strided), linear [N, 3, 3] (may be strided).
// Float or double, all of one dtype. Differentiable in every input when grad mode is on and one of
// them requires grad; a plain loop otherwise.
CovarianceChain covariance_chain(const torch::Tensor& rotations, const torch::Tensor& log_scales,
                                 const torch::Tensor& geometry_raw, const torch::Tensor& fusion_raw,
                                 const torch::Tensor& linear);

// The same chain in LibTorch ops from dSigma and dSigma^f, differentiable by autograd: the reference
// covariance_chain is measured and tested against.
CovarianceChain covariance_chain_ops(const torch::Tensor& rotations, const torch::Tensor& log_scales,
                                     const torch::Tensor& dsigma, const torch::Tensor& dsigma_f,
                                     const torch::Tensor& linear);

}  // namespace handscs
