// Moves an avatar's learnable state (Gaussians, embeddings, generator and decoder weights) into and
// out of a Checkpoint, by name; loading checks every name and shape.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "avatar/avatar.h"
#include "data/capture_identity.h"
#include "run/camera_color_transform.h"
#include "run/checkpoint.h"
#include "run/run_config.h"

namespace handscs {

// Adds "gaussians/<name>" and "network/<module>.<param>" tensors.
void store_avatar(Avatar& avatar, Checkpoint& checkpoint);

// Restores an avatar built from `config` and `rig`; `source` names the file in errors.
Avatar restore_avatar(const Checkpoint& checkpoint, const AvatarConfig& config, Rig rig,
                      const std::string& source);

// A trained avatar as a checkpoint file or run folder holds it (open_checkpoint): the file's path,
// the run config stored in it with `overrides` ("a.b=value", as --set) applied, the stored config
// as trained, the avatar restored with that config's model and rig, and its per-camera colour
// transforms (train.camera_color; none for an older checkpoint or with it off). A model.* override
// is refused: the weights fix the model.
struct TrainedAvatar {
  std::string path;
  RunConfig config;          // stored, with the overrides
  RunConfig trained_config;  // stored, as the run trained (no overrides)
  Avatar avatar;             // the first hand's: data.hand's, or the right one of both
  CameraColorTable colors;
  // data.hand both: the left hand's avatar (the checkpoint's "left" section); empty otherwise.
  std::vector<Avatar> left;
  // The capture it trained on (data/capture_identity.h); absent from an older build's checkpoint.
  std::optional<CaptureIdentity> capture_identity;
  // Its hands in the run's first training frame (data/placement.h, a POSES file's frame object);
  // null for an older build's checkpoint.
  nlohmann::json placement;
  Handedness first_hand() const;  // the hand `avatar` is
  // The avatar of hand `side`; null when the checkpoint has none.
  Avatar* hand(Handedness side);
  int64_t gaussian_count();  // over the hands
};
TrainedAvatar open_trained_avatar(const std::string& checkpoint_or_run,
                                  const std::vector<std::string>& overrides = {});
// Throws Error naming the first model.* override, or data.rig / data.flat_hand_mean (the model's rig).
void refuse_model_overrides(const std::vector<std::string>& overrides);

}  // namespace handscs
