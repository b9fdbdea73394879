// What the model benchmarks share: an avatar grown to N Gaussians the way clones grow it, and a
// capture-like camera looking at the hand.
#pragma once

#include <algorithm>
#include <cmath>

#include <torch/types.h>

#include "avatar/avatar.h"
#include "core/camera.h"

namespace bench {

// Grows the avatar to n Gaussians by duplicating random ones with a small jitter (as clones would).
inline void grow(handscs::Avatar& avatar, int64_t n) {
  auto& g = avatar.gaussians();
  if (n <= g.size()) {
    g = g.select(torch::arange(n, torch::kInt64));
    return;
  }
  torch::NoGradGuard no_grad;
  const auto index = torch::randint(g.size(), {n - g.size()}, torch::kInt64);
  auto extra = g.select(index);
  extra.means = (extra.means.detach() + torch::randn_like(extra.means) * 0.002).requires_grad_(true);
  extra.log_scales = (extra.log_scales.detach() - std::log(2.0)).requires_grad_(true);
  g.append(extra);
}

// Opens the decoders' gates to 0.05: realistic, non-zero offsets.
inline void open_gates(handscs::Avatar& avatar) {
  torch::NoGradGuard no_grad;
  for (auto& p : avatar.decoders()->parameters())
    if (p.numel() == 1) p.fill_(0.05);
}

inline handscs::Camera capture_camera(int width, int height) {
  handscs::Camera camera;
  camera.width = width;
  camera.height = height;
  const double f = 1.2 * std::max(width, height);  // InterHand-like focal for 512x334
  camera.K = {f, 0, width / 2.0, 0, f, height / 2.0, 0, 0, 1};
  camera.t = {0, 0, 0.55};
  return camera;
}

}  // namespace bench
