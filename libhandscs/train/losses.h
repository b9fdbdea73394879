// The training objective (paper §3.3): L = L1_rgb + l1 L_mask + l2 (1 - SSIM) + l3 LPIPS
// + l_reg L_reg + l_con L_con. A term whose weight is zero is never computed.
//   L_mask = mean (alpha - mask)^2;  L_reg = mean_i (|dx_i| + |dx^f_i| + |dSigma_i - I|_F +
//   |dSigma^f_i - I|_F + |dc_i| + |dc^f_i|) with smooth norms (finite gradient at zero offsets).
#pragma once

#include <map>
#include <memory>
#include <string>

#include <torch/types.h>

#include "avatar/decoders.h"
#include "metrics/lpips.h"
#include "train/train_config.h"

namespace handscs {

struct LossInputs {
  torch::Tensor rgb;     // [h, w, 3] rendered
  torch::Tensor alpha;   // [h, w] rendered
  torch::Tensor target;  // [h, w, 3] ground truth composited on the same background
  torch::Tensor mask;    // [h, w] in {0, 1}
  const DecodedOffsets* offsets = nullptr;
  torch::Tensor consistency;  // scalar L_con (already weighted by pose similarity), or undefined
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
  const LossWeights& weights() const { return weights_; }
  bool uses_lpips() const { return lpips_ != nullptr && weights_.lpips > 0; }

 private:
  LossWeights weights_;
  std::shared_ptr<const Lpips> lpips_;
};

// L_reg of one set of decoded offsets (mean over Gaussians).
torch::Tensor offset_regularizer(const DecodedOffsets& offsets);

}  // namespace handscs
