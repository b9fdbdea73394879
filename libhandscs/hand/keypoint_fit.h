// Fits a rig to 21 3D keypoints per frame: each frame's pose (global rotation, 15 joint rotations,
// translation) and one shape for the subject, by Levenberg-Marquardt on
//   sum_j rho(|x_j(theta, trans, beta) - k_j|) + priors,
// rho Huber's loss on each joint's distance (a bad keypoint pulls linearly, not quadratically),
// x_j the rig's MANO21 joints (hand/joint_model.h). Joints fix each bone's direction, not its twist
// about itself: a twist prior holds it at zero. A weak pose prior keeps a joint without keypoints
// at the rig's mean pose; one-sided limits keep fingers from bending backwards, sideways or twisting
// beyond what hands do.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/config.h"
#include "hand/joint_model.h"

namespace handscs {

struct KeypointFitConfig {
  int iterations = 40;         // Levenberg-Marquardt steps per frame
  double huber_mm = 10.0;      // joint distance where the loss turns linear (mm)
  // Prior weights, in metres of joint error per unit of the prior's quantity, so they compare
  // with the keypoint term: a radian from the mean pose costs as much as 1 mm of keypoint error.
  double pose_prior = 0.001;
  double twist_prior = 0.01;   // per radian of twist about a bone (joints do not see it)
  double limit_weight = 0.05;  // per radian beyond a joint limit (backwards, sideways, twist)
  // Per unit of a shape coefficient (a standard deviation of the shape space), and beyond
  // shape_limit units the limit weight as well: joints barely see some modes (the built-in
  // hand's thickness moves them ~0.1 mm a unit), which a weak pull alone lets run past the +-10
  // that capture readers accept, while a strong one biases the modes joints do see.
  double shape_prior = 0.0002;
  // Three standard deviations hold most people; a hand beyond them (real palms reach it on the
  // built-in hand, docs/FIT.md) may take more. At most 8: the limit is soft, so a coefficient
  // passes it a little, and capture readers refuse beyond 10.
  double shape_limit = 3.0;
  bool fit_shape = true;       // fit one shape for the subject (false: keep shape zero)
  double smoothing = 0.0;      // sequence fits: weight (m/rad) pulling each pose to the previous one

  template <class V>
  void visit(V& v) {
    v.field("iterations", iterations, "Levenberg-Marquardt steps per frame", 1, 10000);
    v.field("huber_mm", huber_mm, "joint distance (mm) where the loss turns linear", 0.01, 1e6);
    v.field("pose_prior", pose_prior, "pull to the rig's mean pose (m of error per rad)", 0, 10);
    v.field("twist_prior", twist_prior, "pull of each bone's twist to zero (m per rad)", 0, 10);
    v.field("limit_weight", limit_weight, "cost of a finger joint beyond its limits (m per rad)", 0, 10);
    v.field("shape_prior", shape_prior, "pull of the shape to zero (m per unit)", 0, 10);
    v.field("shape_limit", shape_limit, "shape coefficients beyond this many units cost limit_weight", 0.5, 8);
    v.field("fit_shape", fit_shape, "fit one shape for the subject");
    v.field("smoothing", smoothing, "sequence fits: pull of each pose to the previous (m per rad)", 0,
            10);
  }
};

// One hand's keypoints in MANO21 order (metres, world frame); a joint without one has valid 0.
struct HandKeypoints {
  std::array<double, 63> joints{};
  std::array<uint8_t, 21> valid{};
  int num_valid() const;
};

struct HandFit {
  JointParams params;                       // absolute axis-angles, trans, shape
  std::array<double, 63> joints{};          // the fitted rig's MANO21 joints
  std::array<double, 21> residual_mm{};     // distance to each valid keypoint (NaN where none)
  double mean_mm = 0, max_mm = 0;           // over valid keypoints
  double limit_excess = 0;                  // largest excess over a finger joint's limits (rad)
  int iterations = 0;                       // Levenberg-Marquardt steps taken
  bool fitted = false;                      // false: too few keypoints to fit
};

// Fits one frame; with config.fit_shape the shape too, else `shape` stays as given.
HandFit fit_keypoints(const JointModel& model, const HandKeypoints& keypoints,
                      const KeypointFitConfig& config, const std::array<double, kShapeDim>& shape = {});

// Fits a sequence with one shared shape: every frame's pose alone, then all poses and the shape
// together. Frames with fewer than kMinFitKeypoints valid keypoints are not fitted (fitted false).
// With a progress label, a progress line counts the frames of a long sequence (a 5 fps
// InterHand2.6M capture has thousands).
std::vector<HandFit> fit_keypoint_sequence(const JointModel& model,
                                           const std::vector<HandKeypoints>& frames,
                                           const KeypointFitConfig& config,
                                           const std::string& progress_label = "");

// The palm's four points (wrist and the index, middle and pinky bases) fix the hand's rotation;
// a fit needs them and at least one more.
constexpr int kMinFitKeypoints = 5;

// The other hand (its rig, or its joints) must agree this much better than a hand's own to call
// the hands swapped (ratio of distances, or of fit residuals): a hand agrees with its own rig and
// joints within ~1-5 mm, with the other hand's by centimetres (mirrored fingers bend backwards, or
// the other hand lies 10+ cm away). handscs-fit and Capture::open both judge by it.
constexpr double kSwappedHandRatio = 0.5;

// The pose in the rig's file convention: relative to hands_mean unless flat_hand_mean.
std::array<double, kPoseDim> rig_pose(const JointModel& model, const JointParams& params,
                                      bool flat_hand_mean);
// The inverse: absolute axis-angles from a pose in the rig's convention.
std::array<double, kPoseDim> absolute_pose(const JointModel& model,
                                           const std::array<double, kPoseDim>& pose,
                                           bool flat_hand_mean);

// Bend of each finger joint: the angle (rad) between its parent bone and its child bone in the
// posed joints [21 * 3]; 15 values in MANO joint order 1..15 (determined by the joints alone).
std::array<double, 15> joint_bend_angles(const double* joints);

}  // namespace handscs
