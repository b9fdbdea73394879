// Test fixtures: a camera that sees the built-in hand, and a small HandSCS avatar of it for gradient
// checks in double precision (narrow decoders and generator, 2 virtual bones) with every decoder
// gate open at 0.3, so the decoders' offsets reach the output.
#pragma once

#include <torch/types.h>

#include "avatar/avatar.h"
#include "core/camera.h"

namespace handscs_test {

// Looks at the built-in hand (about 0.2 m across around the origin) from 0.6 m along +z.
inline handscs::Camera hand_view_camera(int width, int height) {
  handscs::Camera camera;
  camera.width = width;
  camera.height = height;
  const double f = 1.1 * width;
  camera.K = {f, 0, width / 2.0, 0, f, height / 2.0, 0, 0, 1};
  camera.t = {0, 0, 0.6};
  return camera;
}

inline handscs::Avatar small_double_avatar() {
  handscs::AvatarConfig config;
  config.decoder_hidden = 8;
  config.embedding_dim = 4;
  config.scs.virtual_bones = 2;
  config.scs.generator_hidden = 8;
  handscs::Avatar avatar(config, handscs::load_rig_source("builtin"));
  avatar.set_dtype(torch::kFloat64);
  torch::NoGradGuard no_grad;
  for (auto& p : avatar.decoders()->parameters())
    if (p.numel() == 1) p.fill_(0.3);
  return avatar;
}

}  // namespace handscs_test
