// The training objective (paper §3.3): L = L1_rgb + l1 L_mask + l2 (1 - SSIM) + l3 LPIPS
// + l_reg L_reg + l_con L_con. A term whose weight is zero is never computed.
//   L_mask = mean (alpha - mask)^2;  L_reg = mean_i (|dx_i| + |dSigma_i - I|_F + |dc_i|) as the
//   paper writes it (reg_terms "paper"), or with the fusion offsets' |dx^f_i| + |dSigma^f_i - I|_F +
//   |dc^f_i| too (reg_terms "all"); smooth norms (finite gradient at zero offsets).
#pragma once

#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <torch/types.h>

#include "avatar/decoders.h"
#include "metrics/lpips.h"
#include "run/train_config.h"

namespace handscs {

struct LossInputs {
  torch::Tensor rgb;     // [h, w, 3] rendered
  torch::Tensor alpha;   // [h, w] rendered
  torch::Tensor target;  // [h, w, 3] ground truth composited on the same background
  torch::Tensor mask;    // [h, w] in {0, 1}
  const DecodedOffsets* offsets = nullptr;
  torch::Tensor decoded_rows;  // AvatarState::decoded_rows: L_reg averages over these (undefined: all)
  torch::Tensor consistency;  // scalar L_con (already weighted by pose similarity), or undefined
  bool lpips_step = true;     // a step that takes LPIPS (train.loss.lpips_every)
};

struct LossResult {
  torch::Tensor total;                    // scalar to backpropagate
  std::map<std::string, double> terms;    // unweighted value of every computed term
};

class Objective {
 public:
  // lpips may be null (LPIPS weight 0 or no weights file): the LPIPS term is then skipped.
  Objective(const LossWeights& weights, std::shared_ptr<const Lpips> lpips);
  LossResult compute(const LossInputs& in) const;
  // The terms of the pose alone (L_reg on in.offsets, L_con): a second hand's, which its own
  // decoding has (data.hand both; rgb, alpha, target and mask unused).
  LossResult pose_terms(const LossInputs& in) const;
  const LossWeights& weights() const { return weights_; }
  bool uses_lpips() const { return lpips_ != nullptr && weights_.lpips > 0; }

 private:
  LossWeights weights_;
  std::shared_ptr<const Lpips> lpips_;
};

// An image side times a scale (train.loss.lpips_scale, train.resolution_scale): rounded, at least 1.
int64_t scaled_side(int64_t side, double scale);

// Per-Gaussian smooth norms [N] of every decoded offset, named dx, dsigma (|dSigma - I|_F), dc,
// dx_f, dsigma_f, dc_f in that order (L_reg's terms; the trainer logs their means).
std::vector<std::pair<std::string, torch::Tensor>> offset_norms(const DecodedOffsets& offsets);

// L_reg of one set of decoded offsets (mean over Gaussians); terms "paper" (dx, dSigma, dc) or "all"
// (the fusion offsets as well). With rows ([K] int64, AvatarState::decoded_rows), the mean over
// those Gaussians only: the others were not decoded this step.
torch::Tensor offset_regularizer(const DecodedOffsets& offsets, LossWeights::RegTerms terms,
                                 const torch::Tensor& rows = {});

}  // namespace handscs
