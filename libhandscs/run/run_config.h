// The whole configuration of a run: capture (data), avatar (model), training and evaluation.
// configs/base.json holds its defaults and docs/CONFIG.md documents every key (both generated from
// this struct by `handscs-train --print-defaults` / `--print-docs`, and checked by a test).
#pragma once

#include <string>
#include <type_traits>
#include <vector>

#include "avatar/avatar_config.h"
#include "data/capture_config.h"
#include "metrics/eval_config.h"
#include "run/train_config.h"

namespace handscs {

struct RunConfig {
  CaptureConfig data;
  AvatarConfig model;
  TrainConfig train;
  EvalConfig eval;

  template <class V>
  void visit(V& v) {
    v.section("data", data, "capture: which images, split rule, masks, cache");
    v.section("model", model, "avatar: Gaussians, embeddings, decoders, SCS (its rig: data.rig)");
    v.section("train", train, "optimisation: losses, learning rates, densification, checkpoints");
    v.section("eval", eval, "evaluation protocol: SSIM variant, LPIPS, masks, background");
    // One rig for masks and avatar: data.rig and data.flat_hand_mean serve the model.
    if constexpr (std::is_same_v<V, ConfigReader>) {
      model.rig = data.rig;
      model.flat_hand_mean = data.flat_hand_mean;
    }
  }

  // model.rig and model.flat_hand_mean, keys before data.* served the model: still read from
  // files and checkpoints written then (core/config.h, DeprecatedKey).
  static const std::vector<DeprecatedKey>& deprecated_keys();
};

// The rig hand `side`'s avatar is built on: data.rig (model.rig) as the capture poses it for
// that hand's masks (capture_rig: a built-in name is the built-in hand of that side).
Rig avatar_rig(const RunConfig& config, Handedness side);
// A one-hand run's hand (data.hand); throws Error naming `what` for data.hand both.
Handedness avatar_hand(const RunConfig& config, const std::string& what);

// What makes two runs one experiment, beyond the model: the data.* keys that choose which images
// train and which test (capture, split, held-out poses, cameras, hand, rig). The differences
// between `stored` and `given` as "data.key: a -> b" lines (empty when a resume keeps them).
std::vector<std::string> experiment_differences(const RunConfig& stored, const RunConfig& given);

// Cross-section checks that single fields cannot express (e.g. data.rig and model.rig, which a
// config read from JSON sets alike, must agree when set in code).
// `source` names the config in errors.
void validate_run_config(const RunConfig& config, const std::string& source);
// eval.background's values in [0, 1] (part of validate_run_config; evaluation checks a stored
// config's with this alone). `source` names the config in errors.
void check_eval_background(const RunConfig& config, const std::string& source);

}  // namespace handscs
