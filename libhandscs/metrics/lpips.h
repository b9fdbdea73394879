// LPIPS v0.1 (Zhang et al. 2018), differentiable; a distance per image pair and a training loss.
// d(x, y) = sum_t mean_hw( w_t . (n(f_t(x)) - n(f_t(y)))^2 ), n(f) = f / (sqrt(sum_c f^2) + 1e-10),
// f_t = tap t of the backbone (AlexNet or VGG16) on the scaling layer's output (z - shift) / scale.
//
// Input convention: [B, 3, H, W] RGB. LpipsConfig::input_range says what the values mean:
//   "zero_one"           images in [0, 1], rescaled to [-1, 1] (official lpips with normalize=True);
//   "minus_one_one"      images already in [-1, 1] (official lpips default);
//   "zero_one_unscaled"  images in [0, 1] fed as they are (reproduces peers that skip the rescale).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <torch/types.h>

#include "metrics/lpips_nets.h"
#include "metrics/lpips_weights.h"

namespace handscs {

struct LpipsConfig {
  std::string weights;                   // torch.save dict file; empty = no LPIPS
  std::string net = "alex";              // backbone: "alex" or "vgg" (must match the file)
  std::string input_range = "zero_one";  // see above

  template <class V>
  void visit(V& v) {
    v.field("weights", weights, "LPIPS weight file (torch.save dict, docs/METRICS.md); empty = skip");
    v.choice("net", net, {"alex", "vgg"}, "LPIPS backbone, matching the weight file");
    v.choice("input_range", input_range, {"zero_one", "minus_one_one", "zero_one_unscaled"},
             "meaning of input values: [0,1] rescaled, [-1,1], or [0,1] fed unscaled (some peers)");
  }
};

// LPIPS's normalisation epsilon (lpips.normalize_tensor): keeps n(f) finite for zero features.
constexpr double kLpipsNormEps = 1e-10;

// Channel unit-normalisation f / (|f|_c + 1e-10) for [B, C, H, W]. Where a feature vector is all
// zero the norm's gradient is taken as 0 (the true derivative of |f| there is undefined and autograd
// would give NaN), so the gradient is the finite f-direction term 1/1e-10.
torch::Tensor unit_normalize_channels(const torch::Tensor& features);  // [B, C, H, W]

class Lpips {
 public:
  // Loads config.weights for config.net; throws Error naming the file (and key) when it is missing
  // or wrong. Requires a non-empty config.weights.
  explicit Lpips(const LpipsConfig& config);
  // From tensors already in memory (`source` names them in errors).
  Lpips(const LpipsNetSpec& spec, const TensorDict& weights, const std::string& input_range,
        const std::string& source);

  // LPIPS distance per image pair: [B] (lpips_from_layers of layer_distances). Differentiable in
  // x and y.
  torch::Tensor distance(const torch::Tensor& x,         // [B, 3, H, W], see input_range
                         const torch::Tensor& y) const;  // [B, 3, H, W]

  // Per-tap distance maps w_t . (n(f_t(x)) - n(f_t(y)))^2 at each tap's resolution:
  // [B, 1, h_t, w_t] for the five taps (lpips_spatial.h brings them to image resolution). When no
  // gradient is wanted they come from lpips_tap_distance (one fused pass, lpips_tap_distance.h).
  std::vector<torch::Tensor> layer_distances(const torch::Tensor& x,         // [B, 3, H, W]
                                             const torch::Tensor& y) const;  // [B, 3, H, W]

  // The five taps of the backbone for `images` (after input range and scaling layer).
  std::vector<torch::Tensor> features(const torch::Tensor& images) const;  // [B, 3, H, W]

  // Smallest image side (pixels, square images) the backbone accepts: below it a pooling window or
  // a convolution no longer fits (features() refuses such images).
  int64_t min_image_side() const;

  // A copy whose weights have `dtype` (inputs must have the weights' dtype; float32 by default).
  Lpips to(torch::Dtype dtype) const;

  torch::Dtype dtype() const;

 private:
  LpipsNetSpec spec_;
  std::string input_range_;
  std::vector<std::vector<std::pair<torch::Tensor, torch::Tensor>>> convs_;  // per stage: (w, b)
  std::vector<torch::Tensor> lins_;                                          // [1, C_t, 1, 1]
  torch::Tensor shift_;                                                      // [1, 3, 1, 1]
  torch::Tensor scale_;                                                      // [1, 3, 1, 1]
};

// The LPIPS distance from the per-tap maps: sum over taps of each map's spatial mean, [B].
torch::Tensor lpips_from_layers(const std::vector<torch::Tensor>& layers);  // [B, 1, h_t, w_t] each

// Training loss: mean over the batch of lpips.distance(pred, target); a scalar.
torch::Tensor lpips_loss(const Lpips& lpips,
                         const torch::Tensor& pred,     // [B, 3, H, W]
                         const torch::Tensor& target);  // [B, 3, H, W]

}  // namespace handscs
