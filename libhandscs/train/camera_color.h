// Per-camera colour response (train.camera_color, beyond the paper): each training camera gets a
// colour transform, learned with the avatar, that maps the avatar's own colours to what that camera
// records. A rig's cameras differ in exposure gain and white balance (InterHand2.6M's do; the
// realistic synthetic capture simulates it, synth/camera_response.h); with one colour per Gaussian
// the avatar would learn the cameras' average and be wrong in each of them.
//
// A camera's transform is out = A c + b, applied to the avatar's colours c. Rendering is linear in
// the Gaussians' colours, so it applies to a rendered image as
//   out = A (rgb - (1 - alpha) bg) + alpha b + (1 - alpha) bg
// (the background untouched, the bias weighted by coverage): exactly the image of the Gaussians
// with transformed colours. gain: A = diag(1 + d), 6 parameters (d, b); affine: A = I + D, 12
// parameters (D row-major, b). All parameters are zero at the identity.
//
// Reference: colour could move freely between the Gaussians and the cameras (halve every colour,
// double every gain), so after each step the parameters' mean over the training cameras is
// subtracted: the mean transform stays the identity, and the avatar's own colours are those of the
// average camera, which is what a camera it never saw gets. A runaway transform (a monochrome
// camera kept with data.drop_monochrome = false, a camera whose images are all dark) is clamped to
// the stated ranges below, with a warning naming the camera.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <torch/types.h>

#include "run/camera_color_transform.h"
#include "run/checkpoint.h"
#include "run/train_config.h"

namespace handscs {

class CameraColors {
 public:
  // Stated ranges: a gain (a diagonal entry of A) outside [kMinGain, kMaxGain], an off-diagonal
  // entry or a bias beyond +-kMaxCross / +-kMaxBias is a runaway. The synthetic rig's gains vary by
  // 12% and its white balance by 5%, real rigs' exposures by well under a factor of two: a factor
  // of two either way is no camera's colour response but a camera that records something else
  // (grey, black). Biases of a quarter of the range and cross terms of a half likewise.
  static constexpr double kMinGain = 0.5, kMaxGain = 2.0;
  static constexpr double kMaxCross = 0.5;
  static constexpr double kMaxBias = 0.25;

  // One transform per camera id (the training cameras), all at the identity.
  CameraColors(TrainConfig::CameraColor mode, std::vector<std::string> camera_ids);

  // The learned parameters [C, width] (a leaf that requires grad; the optimiser points at it).
  torch::Tensor& parameters() { return params_; }
  const torch::Tensor& parameters() const { return params_; }
  // Row of a camera id, -1 for a camera without a transform.
  int64_t row(const std::string& camera_id) const;
  // The transform (A | b) [3, 4] of row `row` (differentiable in the parameters).
  torch::Tensor matrix(int64_t row) const;
  // weight x the sum of squared parameters (the distance from the identity) of every camera.
  torch::Tensor penalty(double weight) const;

  // After an optimiser step: clamps every parameter into the stated ranges (warning once per
  // camera and kind the first time it runs away, when `warn`), then subtracts the mean over the
  // cameras so that the mean transform is the identity.
  void project(bool warn);

  // Per camera: the mean gain (mean diagonal of A), for metrics and the run's camera_color.csv.
  std::map<std::string, double> summary() const;
  // camera_id, the 12 entries of (A | b) row-major.
  std::string to_csv() const;

  // Checkpoint: "camera_color/params" and meta "camera_color" {mode, cameras}.
  void store(Checkpoint& checkpoint) const;
  // Restores store()'s parameters (rows matched by camera id; a camera the checkpoint lacks stays
  // at the identity). Returns false when the checkpoint holds none (an older checkpoint, or one
  // trained with camera_color off): the transforms stay at the identity.
  bool load(const Checkpoint& checkpoint, const std::string& source);

 private:
  TrainConfig::CameraColor mode_;
  std::vector<std::string> camera_ids_;
  torch::Tensor params_;                // [C, width] float32
  std::vector<std::string> warned_;     // "camera/kind" already reported
};

}  // namespace handscs
