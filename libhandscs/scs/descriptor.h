// Structural coordinate descriptor (paper §3.1.2): per Gaussian and bone (u, v), with r = j_u - x and
// b = j_v - j_u, P = d * rho where rho = r.b / (|r| |b|) and
//   static bones (posed skeleton, x = LBS-posed centre):   d = exp(-|r|^2 / tau^2)
//   virtual bones (endpoints p, q; x = canonical centre):  d = |r|
// Norms are floored at eps so a Gaussian on a joint or a zero-length bone stays finite.
#pragma once

#include <torch/types.h>

#include "scs/topology.h"

namespace handscs {

// x: [N, 3] Gaussian centres; joints: [21, 3]; returns [N, E] (E = topology.size()).
torch::Tensor static_descriptor(const torch::Tensor& x, const torch::Tensor& joints,
                                const BoneTopology& topology, double tau, double eps);

// The same static descriptor in one pass over the Gaussians: the LibTorch form above builds ~15
// [N, E, 3]- and [N, E]-sized temporaries. Under autograd (grad mode on, x or joints requiring grad)
// it is one op whose backward is written out (descriptor.cpp). Float or double; equal to the LibTorch
// form to rounding, values and gradients (tests/scs/test_descriptor.cpp).
torch::Tensor static_descriptor_loop(const torch::Tensor& x, const torch::Tensor& joints,
                                     const BoneTopology& topology, double tau, double eps);

// x: [N, 3]; start, end: [M, 3] virtual bone endpoints p, q; returns [N, M].
// With d = |r|, d * rho = r.b / |b| exactly (for |r| >= eps), which is what is computed: it is smooth
// where the cosine alone is not.
torch::Tensor virtual_descriptor(const torch::Tensor& x, const torch::Tensor& start,
                                 const torch::Tensor& end, double eps);

}  // namespace handscs
