#include "data/joint_pose_fit.h"

#include <chrono>
#include <filesystem>

#include <spdlog/spdlog.h>

#include "core/atomic_file.h"
#include "core/config.h"
#include "core/file_stamp.h"
#include "core/hash.h"
#include "data/cache_files.h"
#include "data/capture.h"  // capture_rig
#include "data/interhand_records.h"  // interhand_hand_joints

namespace handscs {

namespace fs = std::filesystem;

namespace {

// Bumped when the cached fit's meaning changes (the solver, the file's fields).
constexpr int kFitCacheVersion = 1;

std::string cache_key(const std::string& joint_file, const CaptureConfig& c, Handedness side) {
  FileStamp stamp;
  read_file_stamp(joint_file, stamp);
  FileStamp rig_stamp;
  if (c.rig.rfind("builtin", 0) != 0) read_file_stamp(c.rig, rig_stamp);
  KeypointFitConfig fit = c.joint_fit;
  const json key = {{"version", kFitCacheVersion}, {"joint_file", fs::absolute(joint_file).string()},
                    {"size", stamp.size}, {"mtime_ns", stamp.mtime_ns}, {"capture", c.capture},
                    {"hand", hand_name(side)}, {"rig", c.rig}, {"rig_size", rig_stamp.size},
                    {"rig_mtime_ns", rig_stamp.mtime_ns}, {"flat_hand_mean", c.flat_hand_mean},
                    {"fit", config_to_json(fit)}};
  return key.dump();
}

// One hand's fits into `out` (its frames, from the cache or fitted now).
void fit_one_hand(const std::map<int64_t, InterHandJoints>& joints, const std::string& joint_3d_json,
                  const CaptureConfig& c, Handedness side, std::map<int64_t, RecordFrame>& out) {
  const bool right = side == Handedness::right;
  const std::string hand = hand_name(side);
  const std::string key = cache_key(joint_3d_json, c, side);
  const std::string name = fs::path(joint_3d_json).filename().string() + ".capture" + std::to_string(c.capture) +
                           ".fit-" + hand + "-" + std::to_string(fnv1a64(key)) + ".json";
  const std::vector<std::string> files = cache_files_for(c.annotation_cache, joint_3d_json, name, "annotations");
  // The cached fits: per frame, the MANO parameters and the mean residual.
  json fits;
  for (const std::string& file : files) {
    if (!fs::exists(file)) continue;
    try {
      json cached = json::parse(read_file(file));
      if (cached.value("key", "") == key) {
        fits = cached["frames"];
        break;
      }
    } catch (const std::exception& e) {
      spdlog::warn("{}: unreadable fit cache ({}): fitting again", file, e.what());
    }
  }
  if (fits.is_null()) {
    const Rig rig = capture_rig(c, side);
    const JointModel model = make_joint_model(rig);
    std::vector<int64_t> ids;
    std::vector<HandKeypoints> frames;
    for (const auto& [frame, entry] : joints) {
      if (entry.hand_type != "interacting" && entry.hand_type != hand) continue;
      HandKeypoints k;
      interhand_hand_joints(entry, right, k.joints, k.valid);
      if (k.num_valid() < kMinFitKeypoints) continue;
      ids.push_back(frame);
      frames.push_back(k);
    }
    const auto start = std::chrono::steady_clock::now();
    spdlog::info("{}: fitting the {} hand to {} frames' joints (pose_source joints; cached for the next open)",
                 joint_3d_json, hand, frames.size());
    const std::vector<HandFit> results = fit_keypoint_sequence(model, frames, c.joint_fit, "fit " + hand + " hand to joints");
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    spdlog::info("{}: {} frames fitted in {:.1f} s ({:.2f} ms a frame)", joint_3d_json, frames.size(), seconds,
                 frames.empty() ? 0.0 : 1e3 * seconds / frames.size());
    fits = json::array();
    for (size_t i = 0; i < ids.size(); ++i) {
      const auto pose = rig_pose(model, results[i].params, c.flat_hand_mean);
      fits.push_back({{"frame", ids[i]}, {"pose", pose}, {"shape", results[i].params.shape},
                      {"trans", results[i].params.trans}, {"mean_mm", results[i].mean_mm}});
    }
    std::string problem;
    if (!files.empty() &&
        write_first_writable(files, json{{"key", key}, {"frames", fits}}.dump() + "\n", problem).empty())
      spdlog::warn("{}: the joint fits could not be cached ({})", joint_3d_json, problem);
  }
  for (const json& f : fits) {
    const int64_t frame = f["frame"].get<int64_t>();
    RecordHand hand;
    hand.mano.pose = f["pose"].get<std::array<double, 48>>();
    hand.mano.shape = f["shape"].get<std::array<double, 10>>();
    hand.mano.trans = f["trans"].get<std::array<double, 3>>();
    const double mean_mm = f["mean_mm"].get<double>();
    if (mean_mm > c.poor_joint_fit_mm) hand.fit_problem = "poor joint fit";
    hand.has_joints = true;
    interhand_hand_joints(joints.at(frame), right, hand.joints, hand.joint_valid);
    (right ? out[frame].right : out[frame].left) = hand;
  }
}

}  // namespace

std::map<int64_t, RecordFrame> fit_joint_frames(const std::map<int64_t, InterHandJoints>& joints,
                                                const std::string& joint_3d_json, const CaptureConfig& c) {
  std::map<int64_t, RecordFrame> out;
  for (const auto& [frame, entry] : joints) out[frame] = RecordFrame{};
  for (const Handedness side : hand_sides(c.hand)) fit_one_hand(joints, joint_3d_json, c, side, out);
  return out;
}

}  // namespace handscs
