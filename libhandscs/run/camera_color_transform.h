// The per-camera colour transforms (train.camera_color) as training stores them and evaluation and
// rendering apply them: the transform of each mode's parameters, its application to a rendered
// image, and the table of a checkpoint's transforms by camera id. Learning them is training's
// (train/camera_color.h, whose header explains the model).
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <torch/types.h>

#include "run/checkpoint.h"
#include "run/train_config.h"

namespace handscs {

// out = A (rgb - (1 - alpha) bg) + alpha b + (1 - alpha) bg for rgb [h, w, 3], alpha [h, w],
// background [3] and matrix [3, 4] = (A | b); differentiable in rgb, alpha and matrix.
torch::Tensor apply_color_transform(const torch::Tensor& rgb, const torch::Tensor& alpha,
                                    const std::array<float, 3>& background,
                                    const torch::Tensor& matrix);

// Parameters per camera of each mode (0 for off).
int64_t camera_color_width(TrainConfig::CameraColor mode);
// [C, 3, 4] transforms (A | b) from parameters [C, width] (differentiable).
torch::Tensor camera_color_matrices(TrainConfig::CameraColor mode, const torch::Tensor& params);
std::string camera_color_name(TrainConfig::CameraColor mode);

// Where the diagonal of A sits in a row of parameters (the gains), and where the bias starts.
std::vector<int64_t> camera_color_diagonal_columns(TrainConfig::CameraColor mode);
int64_t camera_color_bias_column(TrainConfig::CameraColor mode);

// What evaluation and rendering apply: the transforms a checkpoint holds, by camera id.
struct CameraColorTable {
  TrainConfig::CameraColor mode = TrainConfig::CameraColor::off;
  std::map<std::string, torch::Tensor> matrices;  // camera id -> [3, 4] (A | b), float32

  // The camera's transform, none for a camera the avatar never saw (or camera_color off).
  std::optional<torch::Tensor> find(const std::string& camera_id) const;
  // From a checkpoint: empty (mode off) when it holds no transforms.
  static CameraColorTable from_checkpoint(const Checkpoint& checkpoint, const std::string& source);
};

}  // namespace handscs
