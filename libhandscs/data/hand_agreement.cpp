#include "data/hand_agreement.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include "core/error.h"
#include "hand/joint_model.h"
#include "hand/keypoint_fit.h"  // absolute_pose, kMinFitKeypoints, kSwappedHandRatio
#include "hand/rig_mirror.h"

namespace handscs {

namespace {

// Frames measured per hand (evenly spaced): a swap or a copy concerns every frame, so a few tell,
// and the check stays a fraction of a second on a release-size capture.
constexpr size_t kSampledFrames = 32;
// Valid joints a frame needs to be measured (as a keypoint fit needs: the palm and one more).
constexpr int kMinJoints = kMinFitKeypoints;
// Beyond this median distance a hand's parameters do not describe its joints whatever the rest
// says: annotations of one hand agree within millimetres to about a centimetre (fitting noise, a
// rig that is not the annotator's), and a hand is ~18 cm long.
constexpr double kDisagreeMm = 50.0;
constexpr double kMm = 1000.0;

const RecordHand* hand_of(const RecordFrame& frame, Handedness side) {
  const std::optional<RecordHand>& hand = side == Handedness::right ? frame.right : frame.left;
  return hand ? &*hand : nullptr;
}

// Mean distance (mm) between `posed` and the annotated joints, over those valid in `annotated`;
// NaN below kMinJoints.
double mean_distance_mm(const double* posed, const RecordHand& annotated) {
  double sum = 0;
  int count = 0;
  for (int j = 0; j < 21; ++j) {
    if (!annotated.joint_valid[j]) continue;
    const double dx = posed[3 * j] - annotated.joints[3 * j], dy = posed[3 * j + 1] - annotated.joints[3 * j + 1],
                 dz = posed[3 * j + 2] - annotated.joints[3 * j + 2];
    sum += std::sqrt(dx * dx + dy * dy + dz * dz);
    ++count;
  }
  return count >= kMinJoints ? kMm * sum / count : std::nan("");
}

int valid_joints(const RecordHand& hand) {
  return static_cast<int>(std::count(hand.joint_valid.begin(), hand.joint_valid.end(), 1));
}

// The joints of `params` posed on `model`, read in `model`'s own convention (its hands_mean).
std::array<double, 63> posed_joints(const JointModel& model, const ManoParams& params, bool flat_hand_mean) {
  JointParams p;
  p.pose = absolute_pose(model, params.pose, flat_hand_mean);
  p.trans = params.trans;
  p.shape = params.shape;
  std::array<double, 63> joints{};
  joint_positions(model, p, joints.data());
  return joints;
}

// Median of the finite values; NaN when there are none.
double median(std::vector<double> values) {
  values.erase(std::remove_if(values.begin(), values.end(), [](double v) { return !std::isfinite(v); }),
               values.end());
  if (values.empty()) return std::nan("");
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  const double upper = values[mid];
  if (values.size() % 2) return upper;
  return 0.5 * (upper + *std::max_element(values.begin(), values.begin() + mid));
}

}  // namespace

HandAgreement measure_hand_agreement(const CaptureRecords& records, Handedness side, const Rig& rig,
                                     bool flat_hand_mean, const std::set<int64_t>& selected) {
  const Handedness other_side = side == Handedness::right ? Handedness::left : Handedness::right;
  std::vector<const RecordFrame*> measurable;
  for (const auto& [frame_idx, frame] : records.frames) {
    if (!selected.empty() && !selected.count(frame_idx)) continue;
    const RecordHand* hand = hand_of(frame, side);
    if (hand && hand->has_joints && valid_joints(*hand) >= kMinJoints) measurable.push_back(&frame);
  }
  HandAgreement out;
  out.side = side;
  const size_t n = measurable.size();
  const size_t samples = std::min(n, kSampledFrames);
  if (!samples) {
    out.own_mm = out.other_rig_mm = out.other_joints_mm = std::nan("");
    return out;
  }
  const JointModel own_model = make_joint_model(rig);
  const JointModel other_model = make_joint_model(mirror_rig(rig));
  std::vector<double> own, other_rig, other_joints;
  for (size_t s = 0; s < samples; ++s) {
    const RecordFrame& frame = *measurable[s * n / samples];
    const RecordHand& hand = *hand_of(frame, side);
    const std::array<double, 63> posed = posed_joints(own_model, hand.mano, flat_hand_mean);
    own.push_back(mean_distance_mm(posed.data(), hand));
    const std::array<double, 63> mirrored = posed_joints(other_model, hand.mano, flat_hand_mean);
    other_rig.push_back(mean_distance_mm(mirrored.data(), hand));
    const RecordHand* other = hand_of(frame, other_side);
    if (other && other->has_joints) other_joints.push_back(mean_distance_mm(posed.data(), *other));
  }
  out.frames = static_cast<int>(samples);
  out.own_mm = median(own);
  out.other_rig_mm = median(other_rig);
  out.other_joints_mm = median(other_joints);
  return out;
}

void check_hand_agreement(const CaptureRecords& records, const CaptureConfig& config,
                          const std::vector<Rig>& rigs, const std::set<int64_t>& selected,
                          const std::string& config_key) {
  const std::vector<Handedness> sides = hand_sides(config.hand);
  for (size_t h = 0; h < sides.size(); ++h) {
    const HandAgreement a = measure_hand_agreement(records, sides[h], rigs[h], config.flat_hand_mean, selected);
    if (!std::isfinite(a.own_mm)) continue;
    const std::string hand = hand_name(a.side), other = hand_name(sides[h] == Handedness::right ? Handedness::left
                                                                                               : Handedness::right);
    // The file the parameters come from: the hands file (neus), InterHand2.6M's MANO file, else
    // the capture's own file.
    const std::string source = !config.hands_file.empty() ? config.hands_file
                               : records.layout == CaptureConfig::Layout::interhand
                                   ? records.source_files.front() + " (" + records.scope + ")"
                                   : records.scope;
    const std::string where = source + ": the " + hand + " hand's MANO parameters ";
    spdlog::info("{}pose the rig {:.1f} mm from its joints (median of {} frames)", where, a.own_mm, a.frames);
    // Each figure: the median over the sampled frames of a frame's mean joint distance.
    const std::string frames = fmt::format("{} frames", a.frames);
    if (a.other_rig_mm < kSwappedHandRatio * a.own_mm)
      throw Error(where + fmt::format("fit the {} hand's rig far better than its own: posed on it they lie "
                                      "{:.1f} mm from the {} hand's joints, on its own rig {:.1f} mm (medians over "
                                      "{}). The hands' entries are swapped, or the {} hand's were copied in",
                                      other, a.other_rig_mm, hand, a.own_mm, frames, other));
    if (a.other_joints_mm < kSwappedHandRatio * a.own_mm)
      throw Error(where + fmt::format("pose the rig onto the {} hand's joints ({:.1f} mm from them) rather than "
                                      "its own ({:.1f} mm; medians over {}). The hands' parameters are swapped, "
                                      "or the {} hand's were copied in",
                                      other, a.other_joints_mm, a.own_mm, frames, other));
    if (a.own_mm > kDisagreeMm)
      throw Error(where + fmt::format("pose the rig {:.1f} mm from its joints (median over {}), where a hand's "
                                      "own lie within about a centimetre. They belong to another hand (swapped, "
                                      "or copied in from the {} hand), or {}.rig is not the rig they were made for",
                                      a.own_mm, frames, other, config_key));
  }
}

}  // namespace handscs
