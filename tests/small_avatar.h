// Test fixture: a small HandSCS avatar of the built-in hand for gradient checks in double precision
// (narrow decoders and generator, 2 virtual bones) with every decoder gate open at 0.3, so the
// decoders' offsets reach the output.
#pragma once

#include <torch/types.h>

#include "avatar/avatar.h"

namespace handscs_test {

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
