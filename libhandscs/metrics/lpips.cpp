#include "metrics/lpips.h"

#include <ATen/ATen.h>

#include "core/error.h"
#include "metrics/lpips_tap_distance.h"
#include "metrics/max_pool.h"

namespace handscs {

namespace {

// LPIPS ScalingLayer constants: the ImageNet mean/std expressed for inputs in [-1, 1].
const double kShift[3] = {-0.030, -0.088, -0.188};
const double kScale[3] = {0.458, 0.448, 0.450};

}  // namespace

torch::Tensor unit_normalize_channels(const torch::Tensor& features) {
  TORCH_CHECK(features.dim() == 4, "unit_normalize_channels: expected [B, C, H, W], got ",
              features.sizes());
  const auto sum_sq = features.square().sum(1, /*keepdim=*/true);
  const auto nonzero = sum_sq > 0;
  // sqrt only sees positive values, so neither branch of `where` produces a NaN gradient.
  const auto norm =
      at::where(nonzero, at::where(nonzero, sum_sq, at::ones_like(sum_sq)).sqrt(),
                at::zeros_like(sum_sq));
  return features / (norm + kLpipsNormEps);
}

Lpips::Lpips(const LpipsConfig& config)
    : Lpips(lpips_net_spec(config.net),
            [&] {
              require(!config.weights.empty(), "LPIPS: no weight file given (lpips.weights)");
              return read_tensor_dict(config.weights);
            }(),
            config.input_range, config.weights) {}

Lpips::Lpips(const LpipsNetSpec& spec, const TensorDict& weights, const std::string& input_range,
             const std::string& source)
    : spec_(spec), input_range_(input_range) {
  require(input_range == "zero_one" || input_range == "minus_one_one" ||
              input_range == "zero_one_unscaled",
          "LPIPS: unknown input_range \"" + input_range +
              "\" (known: zero_one, minus_one_one, zero_one_unscaled)");
  const TensorDict selected = select_lpips_weights(weights, spec_, source);
  for (size_t t = 0; t < spec_.stages.size(); ++t) {
    std::vector<std::pair<torch::Tensor, torch::Tensor>> stage;
    for (const auto& conv : spec_.stages[t].convs)
      stage.emplace_back(selected.at(conv.key + ".weight"), selected.at(conv.key + ".bias"));
    convs_.push_back(std::move(stage));
    lins_.push_back(selected.at("lin" + std::to_string(t) + ".model.1.weight"));
  }
  shift_ = torch::tensor({kShift[0], kShift[1], kShift[2]}, at::kDouble).view({1, 3, 1, 1}).to(at::kFloat);
  scale_ = torch::tensor({kScale[0], kScale[1], kScale[2]}, at::kDouble).view({1, 3, 1, 1}).to(at::kFloat);
}

torch::Dtype Lpips::dtype() const { return shift_.scalar_type(); }

Lpips Lpips::to(torch::Dtype dtype) const {
  Lpips copy = *this;
  for (auto& stage : copy.convs_)
    for (auto& [w, b] : stage) {
      w = w.to(dtype);
      b = b.to(dtype);
    }
  for (auto& lin : copy.lins_) lin = lin.to(dtype);
  copy.shift_ = shift_.to(dtype);
  copy.scale_ = scale_.to(dtype);
  return copy;
}

std::vector<torch::Tensor> Lpips::features(const torch::Tensor& images) const {
  TORCH_CHECK(images.dim() == 4 && images.size(1) == 3, "lpips: images must be [B, 3, H, W], got ",
              images.sizes());
  TORCH_CHECK(images.scalar_type() == dtype(), "lpips: images are ", images.scalar_type(),
              " but the weights are ", dtype(), " (use Lpips::to)");
  auto h = input_range_ == "zero_one" ? images * 2.0 - 1.0 : images;
  h = (h - shift_) / scale_;
  std::vector<torch::Tensor> taps;
  for (size_t t = 0; t < spec_.stages.size(); ++t) {
    const auto& stage = spec_.stages[t];
    if (stage.pool_kernel > 0) {
      TORCH_CHECK(h.size(2) >= stage.pool_kernel && h.size(3) >= stage.pool_kernel, "lpips: images ",
                  images.size(2), "x", images.size(3), " are too small for LPIPS net '", spec_.name,
                  "' (stage ", t + 1, " gets ", h.size(2), "x", h.size(3), ")");
      h = max_pool_2d_any(h, stage.pool_kernel, stage.pool_stride);
    }
    for (size_t c = 0; c < stage.convs.size(); ++c) {
      const auto& conv = stage.convs[c];
      const int64_t reach = conv.kernel - 2 * conv.padding;
      TORCH_CHECK(h.size(2) >= reach && h.size(3) >= reach, "lpips: images ", images.size(2), "x",
                  images.size(3), " are too small for LPIPS net '", spec_.name, "' (stage ", t + 1,
                  " gets ", h.size(2), "x", h.size(3), ")");
      h = at::relu(at::conv2d(h, convs_[t][c].first, convs_[t][c].second, {conv.stride, conv.stride},
                              {conv.padding, conv.padding}));
    }
    taps.push_back(h);
  }
  return taps;
}

int64_t Lpips::min_image_side() const {
  // Follows features()' size checks on the side length alone (outputs floor((h - k) / s) + 1).
  const auto fits = [this](int64_t h) {
    for (const auto& stage : spec_.stages) {
      if (stage.pool_kernel > 0) {
        if (h < stage.pool_kernel) return false;
        h = (h - stage.pool_kernel) / stage.pool_stride + 1;
      }
      for (const auto& conv : stage.convs) {
        if (h < conv.kernel - 2 * conv.padding) return false;
        h = (h + 2 * conv.padding - conv.kernel) / conv.stride + 1;
      }
    }
    return true;
  };
  int64_t side = 1;
  while (!fits(side)) ++side;  // a few hundred steps at most for AlexNet and VGG16
  return side;
}

std::vector<torch::Tensor> Lpips::layer_distances(const torch::Tensor& x, const torch::Tensor& y) const {
  TORCH_CHECK(x.sizes() == y.sizes(), "lpips: image sizes differ: ", x.sizes(), " vs ", y.sizes());
  const int64_t batch = x.size(0);
  std::vector<torch::Tensor> taps_x, taps_y;
  if (at::GradMode::is_enabled() && x.requires_grad() != y.requires_grad()) {
    // The training loss: only one side needs gradients. The other runs without a graph, so
    // backward skips its conv input gradients (about half of the backward cost).
    auto run = [this](const torch::Tensor& images) {
      if (images.requires_grad()) return features(images);
      at::NoGradGuard no_grad;
      return features(images);
    };
    taps_x = run(x);
    taps_y = run(y);
  } else {
    // Evaluation (or both sides need gradients): one batched pass over both images.
    for (const auto& tap : features(at::cat({x, y}, 0))) {
      taps_x.push_back(tap.narrow(0, 0, batch));
      taps_y.push_back(tap.narrow(0, batch, batch));
    }
  }
  std::vector<torch::Tensor> layers;
  for (size_t t = 0; t < taps_x.size(); ++t) {
    const auto& fx = taps_x[t];
    const auto& fy = taps_y[t];
    // LibTorch's form when a gradient is wanted (max_pool_2d_any's rule), the fused map otherwise.
    const bool graph =
        at::GradMode::is_enabled() && (fx.requires_grad() || fy.requires_grad() || lins_[t].requires_grad());
    if (graph) {
      const auto diff = (unit_normalize_channels(fx) - unit_normalize_channels(fy)).square();
      layers.push_back(at::conv2d(diff, lins_[t]));  // 1x1 lin
    } else {
      layers.push_back(lpips_tap_distance(fx, fy, lins_[t].reshape({-1})));
    }
  }
  return layers;
}

torch::Tensor Lpips::distance(const torch::Tensor& x, const torch::Tensor& y) const {
  return lpips_from_layers(layer_distances(x, y));
}

torch::Tensor lpips_from_layers(const std::vector<torch::Tensor>& layers) {
  TORCH_CHECK(!layers.empty(), "lpips_from_layers: no layers");
  torch::Tensor total;
  for (const auto& layer : layers) {
    const auto mean = layer.mean({1, 2, 3});  // spatial mean of the tap's map
    total = total.defined() ? total + mean : mean;
  }
  return total;
}

torch::Tensor lpips_loss(const Lpips& lpips, const torch::Tensor& pred, const torch::Tensor& target) {
  return lpips.distance(pred, target).mean();
}

}  // namespace handscs
