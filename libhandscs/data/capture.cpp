#include "data/capture.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <tuple>

#include "core/camera_checks.h"
#include "core/error.h"
#include "core/file_stamp.h"
#include "core/hash.h"
#include "core/text.h"
#include "data/capture_impl.h"
#include "data/capture_layout.h"
#include "data/neus_capture.h"
#include "data/hand_agreement.h"
#include "data/handscs_capture.h"
#include "data/image_checks.h"
#include "data/interhand_records.h"
#include "data/mesh_mask.h"
#include "data/scan_cache.h"
#include "hand/finger_length_modes.h"
#include "hand/lbs.h"
#include "hand/rig.h"
#include "hand/rig_mirror.h"

namespace handscs {

namespace fs = std::filesystem;

namespace {

// Paths listed in the one-line skip summary (the rest are counted).
constexpr size_t kSummaryPaths = 5;
// Poses per LBS call when posing the rig for every frame (bounded memory, few calls).
constexpr int64_t kLbsBatch = 128;

// An image that passed the annotation checks, before the image checks.
struct Candidate {
  const RecordImage* image;
  const RecordHand* hand;  // the first of data.hand's hands the frame has
  std::array<const RecordHand*, 2> hands{};  // data.hand both: by Handedness, null where absent
  std::string path;
  Camera camera;
};

// Reason order in the summary line.
const std::vector<std::string> kReasonOrder = {
    "null MANO",       "no joint_3d entry", "poor joint fit",   "other hand",
    "interacting",     "missing image",     "not a file",       "damaged JPEG",
    "oversized image", "unreadable image",  "wrong image size", "black image",
    "hand outside image"};

// Damaged JPEGs and oversized images are each logged with what is wrong, up to this many lines (the
// summary counts all).
constexpr size_t kDamageLines = 10;

std::string make_summary(const std::string& source, const std::vector<SkippedImage>& skipped,
                         size_t total) {
  if (skipped.empty()) return "";
  std::map<std::string, size_t> counts;
  for (const auto& s : skipped) ++counts[s.reason];
  std::vector<std::string> parts;
  for (const auto& reason : kReasonOrder)
    if (counts.count(reason)) parts.push_back(reason + " " + std::to_string(counts[reason]));
  std::vector<std::string> paths;
  for (size_t i = 0; i < skipped.size() && i < kSummaryPaths; ++i) paths.push_back(skipped[i].path);
  std::string line = source + ": skipped " + std::to_string(skipped.size()) + " of " +
                     std::to_string(total) + " images (" + join(parts, ", ") +
                     "): " + join(paths, ", ");
  if (skipped.size() > kSummaryPaths) line += ", ...";
  return line;
}

void check_cameras_exist(const std::vector<std::string>& wanted, const std::set<std::string>& have,
                         const std::string& key, const std::string& scope) {
  for (const auto& id : wanted)
    if (!have.count(id)) throw Error(key + ": camera \"" + id + "\" has no images in " + scope);
}

// Poses every distinct frame: posed vertices [V * 3] float per pose.
std::vector<std::vector<float>> pose_rig(const Rig& rig,
                                         const std::vector<const ManoParams*>& poses,
                                         bool flat_hand_mean) {
  std::vector<std::vector<float>> out;
  out.reserve(poses.size());
  const int64_t count = static_cast<int64_t>(poses.size());
  const auto options = torch::TensorOptions().dtype(torch::kFloat64);
  for (int64_t start = 0; start < count; start += kLbsBatch) {
    const int64_t n = std::min(kLbsBatch, count - start);
    torch::Tensor pose = torch::empty({n, 48}, options);
    torch::Tensor shape = torch::empty({n, 10}, options);
    torch::Tensor trans = torch::empty({n, 3}, options);
    for (int64_t b = 0; b < n; ++b) {
      const ManoParams& p = *poses[start + b];
      std::copy(p.pose.begin(), p.pose.end(), pose[b].data_ptr<double>());
      std::copy(p.shape.begin(), p.shape.end(), shape[b].data_ptr<double>());
      std::copy(p.trans.begin(), p.trans.end(), trans[b].data_ptr<double>());
    }
    LbsOptions lbs_options;
    lbs_options.flat_hand_mean = flat_hand_mean;
    torch::Tensor vertices;
    {
      torch::NoGradGuard no_grad;
      vertices =
          lbs(rig, pose, shape, trans, lbs_options).vertices.to(torch::kFloat32).contiguous();
    }
    for (int64_t b = 0; b < n; ++b) {
      const float* data = vertices[b].data_ptr<float>();
      out.emplace_back(data, data + vertices.size(1) * 3);
    }
  }
  return out;
}

// "size:mtime" of a file, for a cache folder's key ("0:0" when it cannot be stat'ed).
std::string file_stamp(const std::string& path) {
  FileStamp stamp;
  read_file_stamp(path, stamp);
  return std::to_string(stamp.size) + ":" + std::to_string(stamp.mtime_ns);
}

// <cache_dir>/<kind>-<hash of settings>.
std::string cache_folder(const std::string& cache_dir, const char* kind, const std::string& settings) {
  return (fs::path(cache_dir) / (std::string(kind) + "-" + hex16(fnv1a64(settings)))).string();
}

// <cache_dir>/masks-<hash>: the hash covers every setting a mask depends on, so a changed setting
// never reads a stale mask (version 1: mesh_raster centre sampling + mask_refine). The annotation
// files' sizes and times stand for their content; the images are assumed unchanged. InterHand2.6M
// captures keep the key they had before other layouts were read (no layout name in it).
std::string mask_folder(const CaptureConfig& c, const CaptureRecords& records,
                        const std::string& cache_dir) {
  std::ostringstream settings;
  settings << "v1|";
  if (records.layout != CaptureConfig::Layout::interhand) settings << layout_name(records.layout) << "|";
  settings << fs::absolute(records.images_dir).string() << "|" << records.source_files.front();
  for (const auto& file : records.source_files) settings << "|" << file_stamp(file);
  settings << "|" << c.rig << "|" << hand_name(c.hand) << "|" << c.flat_hand_mean << "|"
           << c.mask_refine.enabled << "|" << c.mask_refine.low << "|" << c.mask_refine.high << "|"
           << c.mask_refine.largest_component;
  // Two hands are refined hand by hand (capture_loader.cpp): a key older two-hand caches lack.
  if (c.hand == CaptureConfig::Hands::both) settings << "|refined per hand";
  return cache_folder(cache_dir, "masks", settings.str());
}

// <cache_dir>/undistorted-<hash>: the hash covers the images folder and the calibration files
// (their sizes and times stand for the cameras and coefficients).
std::string undistorted_folder(const CaptureRecords& records, const std::string& cache_dir) {
  std::ostringstream settings;
  settings << "v1|" << layout_name(records.layout) << "|" << fs::absolute(records.images_dir).string();
  for (const auto& file : records.source_files) settings << "|" << file << "|" << file_stamp(file);
  return cache_folder(cache_dir, "undistorted", settings.str());
}

// Train/test lists from the frames: novel_pose splits by held-out pose (each side filtered by its
// camera list), novel_view by camera list.
// novel_pose trains on the poses in [poses.first_train, poses.first_test) and tests on those in
// [poses.first_test, poses.end) (data.train_poses, data.validation_poses).
struct PoseRanges {
  int first_train = 0, first_test = 0, end = 0;
};

void split_frames(const std::vector<FrameInfo>& frames, CaptureConfig::SplitRule rule,
                  const std::set<std::string>& train_cams, const std::set<std::string>& test_cams,
                  const PoseRanges& poses, std::vector<FrameInfo>& train,
                  std::vector<FrameInfo>& test) {
  for (const FrameInfo& f : frames) {
    const bool in_train = train_cams.empty() || train_cams.count(f.camera_id);
    const bool in_test = test_cams.empty() || test_cams.count(f.camera_id);
    const int p = f.pose_index;
    const bool novel_pose = rule == CaptureConfig::SplitRule::novel_pose;
    const bool train_pose = !novel_pose || (p >= poses.first_train && p < poses.first_test);
    const bool test_pose = !novel_pose || (p >= poses.first_test && p < poses.end);
    if (in_train && train_pose) train.push_back(f);
    if (in_test && test_pose) test.push_back(f);
  }
  if (train.empty()) throw Error("capture: no training images left after the split (" + split_rule_name(rule) + ")");
  if (test.empty()) throw Error("capture: no test images left after the split (" + split_rule_name(rule) + ")");
}

}  // namespace

Rig capture_rig(const CaptureConfig& config, Handedness side, const std::string& config_key) {
  const bool left = side == Handedness::left;
  std::error_code ec;
  if (config.rig.rfind(kBuiltinFingersRig, 0) == 0 && fs::exists(fs::path(config.root) / kSynthSettingsFile, ec))
    throw Error(config_key + ".rig: " + config.rig + " reads shape betas 7-9, which a synthetic capture (" +
                (fs::path(config.root) / kSynthSettingsFile).string() +
                " marks one) fills with values its images never showed; use builtin");
  if (config.rig == "builtin" || config.rig == kBuiltinFingersRig)  // the hand of data.hand
    return load_rig_source(config.rig + (left ? ":left" : ""));
  Rig rig = load_rig_source(config.rig);
  if (rig.handedness == side) return rig;
  if (config.hand == CaptureConfig::Hands::both) return mirror_rig(rig);
  throw Error(config_key + ".rig: rig \"" + config.rig + "\" is a " + hand_name(rig.handedness) +
              " hand but " + config_key + ".hand is " +
              hand_name(config.hand));
}

HandParams own_hand(const FrameInfo& frame) {
  return HandParams{frame.pose, frame.shape, frame.trans, frame.joints, frame.joint_valid};
}

FrameInfo frame_of_hand(const FrameInfo& frame, Handedness side) {
  FrameInfo out = frame;
  if (const HandParams* hand = frame.hand(side)) {
    out.pose = hand->pose;
    out.shape = hand->shape;
    out.trans = hand->trans;
    out.joints = hand->joints;
    out.joint_valid = hand->joint_valid;
  }
  return out;
}

void choose_novel_view_cameras(const std::set<std::string>& available, int train_views,
                               int test_views, std::set<std::string>& train,
                               std::set<std::string>& test) {
  const std::vector<std::string> ids(available.begin(), available.end());
  if (ids.size() < 2)
    throw Error("capture: split_rule novel_view needs at least 2 cameras, the capture has " +
                std::to_string(ids.size()));
  const int wanted = train_views + test_views;
  const int n = std::min<int>(wanted, static_cast<int>(ids.size()));
  const int n_test =
      std::clamp(static_cast<int>(std::lround(double(n) * test_views / wanted)), 1, n - 1);
  for (int k = 0; k < n; ++k) {
    const std::string& id = ids[static_cast<size_t>(k) * ids.size() / static_cast<size_t>(n)];
    const bool to_test = (k + 1) * n_test / n > k * n_test / n;
    (to_test ? test : train).insert(id);
  }
}

namespace {

// Capture::open, step by step. Messages name keys as the user wrote them ("data.held_out_poses" in
// a run config): `prefix` is the config section ("data").
std::string key_name(const std::string& prefix, const char* name) { return prefix + "." + name; }

// novel_pose's pose ranges: the held-out tail, the validation poses before it when asked for, and
// the training poses before those (all of them, or the last data.train_poses).
PoseRanges novel_pose_ranges(const CaptureConfig& c, int num_poses, const std::string& prefix) {
  for (const auto& [name, value] : {std::pair<const char*, int>{"train_poses", c.train_poses},
                                    {"validation_poses", c.validation_poses}})
    require(value == 0 || c.split_rule == CaptureConfig::SplitRule::novel_pose,
            key_name(prefix, name) + ": only split_rule novel_pose selects poses (it is " +
                std::to_string(value) + " with " + split_rule_name(c.split_rule) + ")");
  PoseRanges r;
  // novel_view splits by camera: every pose on both sides, whatever held_out_poses says (a capture
  // of one instant has fewer poses than its default).
  if (c.split_rule != CaptureConfig::SplitRule::novel_pose) return {0, num_poses, num_poses};
  r.end = num_poses - c.held_out_poses;  // the training poses end where the held-out ones start
  if (c.validation_poses > 0) {
    if (c.validation_poses >= r.end)
      throw Error(key_name(prefix, "validation_poses") + ": " +
                  std::to_string(c.validation_poses) + " validation poses leave nothing to train on "
                  "(the selection has " + std::to_string(r.end) + " poses before its " +
                  std::to_string(c.held_out_poses) + " held-out ones)");
    r.first_test = r.end - c.validation_poses;
  } else {
    r.first_test = r.end;
    r.end = num_poses;
  }
  if (c.train_poses > r.first_test)
    throw Error(key_name(prefix, "train_poses") + ": " + std::to_string(c.train_poses) +
                " training poses asked for; the selection has " + std::to_string(r.first_test) +
                " before its " +
                (c.validation_poses > 0 ? std::to_string(c.validation_poses) + " validation poses"
                                        : std::to_string(c.held_out_poses) + " held-out poses"));
  r.first_train = c.train_poses == 0 ? 0 : r.first_test - c.train_poses;
  return r;
}

// Step 1: the capture's records in its layout (data/capture_layout.h).
CaptureRecords read_capture_records(const CaptureConfig& c, const std::string& prefix) {
  const CaptureConfig::Layout layout = detect_capture_layout(c.root, c.layout, key_name(prefix, "root"));
  require(c.hands_file.empty() || layout == CaptureConfig::Layout::neus,
          key_name(prefix, "hands_file") + ": only the neus layout reads it (this capture is " + layout_name(layout) + ")");
  if (layout == CaptureConfig::Layout::interhand) return read_interhand_records(c, prefix);
  if (c.pose_source == CaptureConfig::PoseSource::joints)
    throw Error(key_name(prefix, "pose_source") + ": joints is read from InterHand2.6M's joint_3d.json; a " + layout_name(layout) +
                " capture carries its poses in capture.json (fit keypoints into one with handscs-fit)");
  CaptureRecords records =
      layout == CaptureConfig::Layout::neus
          ? read_neus_capture(c, prefix)
          : read_handscs_capture(c.root, layout, c.flat_hand_mean, key_name(prefix, "flat_hand_mean"));
  if (c.sequences.empty()) return records;
  std::set<std::string> present;
  for (const auto& image : records.images) present.insert(image.seq_name);
  for (const auto& seq : c.sequences)
    if (!present.count(seq))
      throw Error(key_name(prefix, "sequences") + ": sequence \"" + seq + "\" has no frames in " +
                  records.index_file + "; it has " + list_text({present.begin(), present.end()}));
  const std::set<std::string> wanted(c.sequences.begin(), c.sequences.end());
  std::vector<RecordImage> kept;
  for (auto& image : records.images)
    if (wanted.count(image.seq_name)) kept.push_back(std::move(image));
  records.images = std::move(kept);
  return records;
}

// Training and test cameras; empty = every camera.
struct CameraSplit {
  std::set<std::string> train, test;
  bool uses(const std::string& id) const {
    return train.empty() || train.count(id) || test.empty() || test.count(id);
  }
};

// data.validation_cameras (novel_view): the listed training cameras become the test set and
// leave training; the test cameras are not opened.
void hold_out_validation_cameras(const CaptureConfig& c, const std::string& prefix,
                                 CameraSplit& cams) {
  const std::string key = key_name(prefix, "validation_cameras");
  require(c.split_rule == CaptureConfig::SplitRule::novel_view,
          key + ": only split_rule novel_view holds out cameras (it is " + split_rule_name(c.split_rule) +
              "; novel_pose holds out poses: " + key_name(prefix, "validation_poses") + ")");
  // novel_view has filled in the training cameras by now.
  for (const auto& id : c.validation_cameras)
    if (!cams.train.count(id))
      throw Error(key + ": camera \"" + id + "\" is not a training camera (the training cameras: " +
                  list_text({cams.train.begin(), cams.train.end()}) + ")");
  cams.test = {c.validation_cameras.begin(), c.validation_cameras.end()};
  if (cams.test.size() >= cams.train.size())
    throw Error(key + ": holds out every training camera (" + std::to_string(cams.train.size()) +
                "): none is left to train on");
  for (const auto& id : cams.test) cams.train.erase(id);
}

// Step 2: the cameras of each side of the split. Every listed camera must have images.
CameraSplit choose_cameras(const CaptureConfig& c, const CaptureRecords& records,
                           const std::string& prefix) {
  std::set<std::string> data_cameras;
  for (const auto& image : records.images) data_cameras.insert(image.camera);
  check_cameras_exist(c.train_cameras, data_cameras, key_name(prefix, "train_cameras"),
                      records.scope);
  check_cameras_exist(c.test_cameras, data_cameras, key_name(prefix, "test_cameras"),
                      records.scope);
  CameraSplit cams;
  cams.train.insert(c.train_cameras.begin(), c.train_cameras.end());
  cams.test.insert(c.test_cameras.begin(), c.test_cameras.end());
  if (c.split_rule == CaptureConfig::SplitRule::novel_view) {
    if (cams.train.empty() && cams.test.empty()) {
      choose_novel_view_cameras(data_cameras, c.novel_view_train_views, c.novel_view_test_views,
                                cams.train, cams.test);
      if (cams.train.size() != static_cast<size_t>(c.novel_view_train_views) ||
          cams.test.size() != static_cast<size_t>(c.novel_view_test_views))
        spdlog::warn("{} = {} and {} = {} ask for {} cameras; {} has {}: using {} training "
                     "and {} test cameras", key_name(prefix, "novel_view_train_views"),
                     c.novel_view_train_views, key_name(prefix, "novel_view_test_views"),
                     c.novel_view_test_views, c.novel_view_train_views + c.novel_view_test_views,
                     records.layout == CaptureConfig::Layout::interhand ? "capture " + std::to_string(c.capture)
                                                   : records.index_file,
                     data_cameras.size(), cams.train.size(), cams.test.size());
    }
    if (cams.train.empty())
      for (const auto& id : data_cameras)
        if (!cams.test.count(id)) cams.train.insert(id);
    for (const auto& id : cams.test)
      if (cams.train.count(id))
        throw Error(key_name(prefix, "test_cameras") + ": camera \"" + id +
                    "\" is also a training camera (novel_view needs disjoint lists)");
  } else if (cams.test.empty()) {
    cams.test = cams.train;  // novel_pose tests the held-out poses from the training views
  }
  if (!c.validation_cameras.empty()) hold_out_validation_cameras(c, prefix, cams);
  return cams;
}

// Step 3: the images of the used cameras that have MANO parameters for the hand, joints, the
// right hand type and a file (cheap checks; the others are added to `skipped`).
std::vector<Candidate> annotated_candidates(const CaptureConfig& c, const CaptureRecords& records,
                                            const CameraSplit& cams,
                                            std::vector<SkippedImage>& skipped, size_t& considered) {
  const bool both = c.hand == CaptureConfig::Hands::both;
  const bool right = c.hand == CaptureConfig::Hands::right;
  const std::string other_hand = right ? "left" : "right";
  std::vector<Candidate> candidates;
  for (const auto& image : records.images) {
    if (!cams.uses(image.camera)) continue;
    ++considered;
    const std::string path = (fs::path(records.images_dir) / image.file_name).string();
    auto m = records.frames.find(image.frame_idx);
    // data.hand both: a hand whose fit failed is absent and the other trains; the image is skipped
    // for the first hand's reason only when neither is usable.
    std::array<const RecordHand*, 2> hands{};  // by Handedness: right, left
    const RecordHand* hand = nullptr;
    if (m != records.frames.end())
      hands = {m->second.right ? &*m->second.right : nullptr, m->second.left ? &*m->second.left : nullptr};
    if (!both) {
      hand = hands[right ? 0 : 1];
    } else {
      const RecordHand* first_present = hands[0] ? hands[0] : hands[1];
      for (const RecordHand*& h : hands)
        if (h && !h->fit_problem.empty()) h = nullptr;
      hand = hands[0] ? hands[0] : hands[1] ? hands[1] : first_present;
    }
    std::string reason;
    if (!hand) {
      reason = "null MANO";
    } else if (!m->second.has_joint_entry) {
      reason = "no joint_3d entry";
    } else if (!hand->fit_problem.empty()) {
      reason = hand->fit_problem;
    } else if (!both && image.hand_type == other_hand) {
      reason = "other hand";
    } else if (!both && image.hand_type == "interacting" && !c.include_interacting) {
      reason = "interacting";
    } else if (std::error_code ec; !fs::is_regular_file(path, ec)) {
      // A link loop or an unreadable folder is skipped like a missing image, its cause logged; a
      // named pipe, a device or a folder in the image's place is named as such.
      std::error_code exists_ec;
      const bool present = !ec && fs::exists(fs::symlink_status(path, exists_ec));
      const bool absent = !present && (!ec || ec == std::errc::no_such_file_or_directory);
      reason = absent ? "missing image" : present ? "not a file" : "unreadable image";
      if (present)
        spdlog::warn("{}: is not a regular file (a named pipe, a device, a folder or a broken link)", path);
      else if (!absent) spdlog::warn("{}: {}", path, ec.message());
    }
    if (!reason.empty()) {
      skipped.push_back({path, reason});
      continue;
    }
    const RecordCamera& record = records.cameras.at(image.camera);
    Camera camera = record.camera;
    camera.width = image.width;
    camera.height = image.height;
    const std::string implausible = camera_intrinsics_problem(camera);
    if (!implausible.empty())
      throw Error(record.where + " (with the " + std::to_string(image.width) + "x" +
                  std::to_string(image.height) + " image size of " + path + "): " + implausible);
    candidates.push_back({&image, hand, both ? hands : std::array<const RecordHand*, 2>{}, path, camera});
  }
  return candidates;
}

// Step 4: every frame_stride-th distinct frame index (pose) is kept; returns frame_idx -> index
// among the kept poses, and drops the candidates of the others.
std::map<int64_t, int> apply_frame_stride(int stride, std::vector<Candidate>& candidates) {
  std::vector<int64_t> frame_ids;
  for (const auto& cand : candidates) frame_ids.push_back(cand.image->frame_idx);
  std::sort(frame_ids.begin(), frame_ids.end());
  frame_ids.erase(std::unique(frame_ids.begin(), frame_ids.end()), frame_ids.end());
  std::map<int64_t, int> strided_pose;
  for (size_t k = 0; k < frame_ids.size(); k += static_cast<size_t>(stride))
    strided_pose.emplace(frame_ids[k], static_cast<int>(strided_pose.size()));
  std::vector<Candidate> kept;
  for (auto& cand : candidates)
    if (strided_pose.count(cand.image->frame_idx)) kept.push_back(std::move(cand));
  candidates = std::move(kept);
  return strided_pose;
}

struct ImageSelection {
  std::vector<size_t> usable;               // candidate indices
  std::vector<std::string> monochrome;      // cameras whose readable images are mostly grey
  size_t dropped_monochrome = 0;
  std::vector<std::string> grey_in_colour;  // grey images (R = G = B) of cameras that record colour
};

// Step 5: image checks (decoded at 1/8 scale, or their results from the scan cache) and hand-in-view
// checks in parallel, then the monochrome cameras; failures are added to `skipped`, damaged JPEGs
// also logged.
ImageSelection select_usable_images(const CaptureConfig& c, const std::string& images_dir,
                                    const std::vector<Candidate>& candidates,
                                    const std::vector<int>& candidate_pose,
                                    const std::vector<std::vector<float>>& posed,
                                    std::vector<SkippedImage>& skipped) {
  const int64_t num_candidates = static_cast<int64_t>(candidates.size());
  std::vector<std::string> paths;
  for (const auto& cand : candidates) paths.push_back(cand.path);
  const std::vector<ImageScan> scans =
      scan_images(paths, scan_cache_files(c.scan_cache, images_dir, c.capture), images_dir);
  std::vector<uint8_t> in_view(candidates.size(), 0);
#pragma omp parallel for schedule(dynamic, 4)
  for (int64_t i = 0; i < num_candidates; ++i) {  // nothing here throws
    const std::vector<float>& vertices = posed[candidate_pose[i]];
    const int64_t num_vertices = static_cast<int64_t>(vertices.size() / 3);
    in_view[i] = !projected_bounds(vertices.data(), num_vertices, candidates[i].camera).empty();
  }

  std::map<std::string, std::pair<int, int>> mono_votes;  // camera -> (grey, readable)
  for (int64_t i = 0; i < num_candidates; ++i) {
    if (!scans[i].readable || scans[i].black) continue;
    auto& votes = mono_votes[candidates[i].image->camera];
    votes.first += scans[i].monochrome;
    votes.second += 1;
  }
  std::set<std::string> mono;
  for (const auto& [id, votes] : mono_votes)
    if (2 * votes.first > votes.second) mono.insert(id);

  ImageSelection selection;
  selection.monochrome.assign(mono.begin(), mono.end());
  size_t named = 0;  // damaged and oversized images, each logged with what is wrong
  for (int64_t i = 0; i < num_candidates; ++i) {
    const Candidate& cand = candidates[i];
    std::string reason;
    if (!scans[i].damage.empty()) {
      reason = "damaged JPEG";
      if (++named <= kDamageLines) spdlog::warn("{}: damaged JPEG ({}): skipped", cand.path, scans[i].damage);
    } else if (!scans[i].oversized.empty()) {
      reason = "oversized image";
      if (++named <= kDamageLines) spdlog::warn("{}: {}: skipped", cand.path, scans[i].oversized);
    } else if (!scans[i].readable) {
      reason = "unreadable image";
    } else if (scans[i].width != cand.image->width || scans[i].height != cand.image->height) {
      reason = "wrong image size";  // its pixels differ from its camera's width x height
    } else if (scans[i].black && c.skip_black_images) {
      reason = "black image";
    } else if (!in_view[i]) {
      reason = "hand outside image";
    }
    if (!reason.empty()) {
      skipped.push_back({cand.path, reason});
      continue;
    }
    if (c.drop_monochrome && mono.count(cand.image->camera)) {
      ++selection.dropped_monochrome;
      continue;
    }
    // A grey image from a colour camera (a converted or substituted file) trains the avatar's
    // colours towards grey for that view: kept, but named.
    if (!mono.count(cand.image->camera) && scans[i].monochrome)
      selection.grey_in_colour.push_back(cand.path);
    selection.usable.push_back(static_cast<size_t>(i));
  }
  if (named > kDamageLines) spdlog::warn("... and {} more damaged or oversized images", named - kDamageLines);
  return selection;
}

HandParams hand_params(const RecordHand& hand) {
  HandParams p;
  for (int k = 0; k < 48; ++k) p.pose[k] = static_cast<float>(hand.mano.pose[k]);
  for (int k = 0; k < 10; ++k) p.shape[k] = static_cast<float>(hand.mano.shape[k]);
  for (int k = 0; k < 3; ++k) p.trans[k] = static_cast<float>(hand.mano.trans[k]);
  if (hand.has_joints) {
    for (int k = 0; k < 63; ++k) p.joints[k] = static_cast<float>(hand.joints[k]);
    p.joint_valid = hand.joint_valid;
  }
  return p;
}

// The rig of every hand data.hand selects (`rigs`, in hand_sides order) posed once per kept pose:
// per pose, the present hands' vertices one after the other (right first).
std::vector<std::vector<float>> pose_hands(const CaptureConfig& c, const std::vector<Rig>& rigs,
                                           const std::vector<Candidate>& candidates,
                                           const std::map<int64_t, int>& strided_pose) {
  const bool both = c.hand == CaptureConfig::Hands::both;
  const std::vector<Handedness> sides = hand_sides(c.hand);
  std::vector<std::vector<float>> posed(strided_pose.size());
  for (size_t h = 0; h < sides.size(); ++h) {
    const Handedness side = sides[h];
    std::vector<const ManoParams*> params(strided_pose.size(), nullptr);
    for (const auto& cand : candidates) {
      const RecordHand* hand = both ? cand.hands[side == Handedness::right ? 0 : 1] : cand.hand;
      if (hand) params[strided_pose.at(cand.image->frame_idx)] = &hand->mano;
    }
    std::vector<int> present;
    std::vector<const ManoParams*> used;
    for (size_t p = 0; p < params.size(); ++p)
      if (params[p]) {
        present.push_back(static_cast<int>(p));
        used.push_back(params[p]);
      }
    const std::vector<std::vector<float>> vertices =
        pose_rig(rigs[h], used, c.flat_hand_mean);
    for (size_t k = 0; k < present.size(); ++k)
      posed[present[k]].insert(posed[present[k]].end(), vertices[k].begin(), vertices[k].end());
  }
  return posed;
}

// Step 6: one usable image as a frame (units: metres; joints in MANO's 21-joint order).
FrameInfo make_frame(const Candidate& cand, int64_t index, int pose_index, bool held_out) {
  const RecordImage& image = *cand.image;
  FrameInfo f;
  f.index = index;
  f.image_id = image.id;
  f.image_path = cand.path;
  f.file_name = image.file_name;
  f.mask_path = image.mask_path;
  f.camera_id = image.camera;
  f.seq_name = image.seq_name;
  f.capture = image.capture;
  f.frame_idx = image.frame_idx;
  f.pose_index = pose_index;
  f.held_out = held_out;
  f.camera = cand.camera;
  for (int k = 0; k < 4; ++k) f.bbox[k] = static_cast<float>(image.bbox[k]);
  const HandParams first = hand_params(*cand.hand);
  f.pose = first.pose;
  f.shape = first.shape;
  f.trans = first.trans;
  f.joints = first.joints;
  f.joint_valid = first.joint_valid;
  for (int side = 0; side < 2; ++side)
    if (cand.hands[side]) f.hands[side] = hand_params(*cand.hands[side]);
  return f;
}

}  // namespace

Capture::Capture(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Capture::Capture(Capture&&) noexcept = default;
Capture& Capture::operator=(Capture&&) noexcept = default;
Capture::~Capture() = default;

Capture Capture::open(const CaptureConfig& config, const std::string& mask_cache_dir,
                      const std::string& config_key) {
  auto impl = std::make_unique<Impl>(static_cast<size_t>(config.cache.budget_mb) << 20);
  impl->config = config;
  const CaptureConfig& c = impl->config;
  require(c.split_rule != CaptureConfig::SplitRule::novel_view || !c.test_cameras.empty() || c.train_cameras.empty(),
          key_name(config_key, "test_cameras") + ": split_rule novel_view with train_cameras needs "
          "a list of test cameras");
  const CaptureRecords records = read_capture_records(c, config_key);
  impl->layout = records.layout;
  const CameraSplit cams = choose_cameras(c, records, config_key);
  std::vector<SkippedImage> skipped;
  size_t considered = 0;
  std::vector<Candidate> candidates = annotated_candidates(c, records, cams, skipped, considered);
  const std::map<int64_t, int> strided_pose = apply_frame_stride(c.frame_stride, candidates);

  // The rig posed once per kept pose (masks and in-view checks).
  std::vector<Rig> rigs;
  for (const Handedness side : hand_sides(c.hand)) rigs.push_back(capture_rig(c, side, config_key));
  // Fitted poses (pose_source joints) agree with their joints by construction.
  if (c.pose_source == CaptureConfig::PoseSource::mano && !strided_pose.empty()) {
    std::set<int64_t> used_frames;
    for (const auto& [frame_idx, pose] : strided_pose) used_frames.insert(frame_idx);
    check_hand_agreement(records, c, rigs, used_frames, config_key);
  }
  const std::vector<std::vector<float>> posed = pose_hands(c, rigs, candidates, strided_pose);
  {
    const Rig& rig = rigs.front();
    impl->num_vertices = rig.num_vertices();
    torch::Tensor faces = rig.faces.to(torch::kInt64).contiguous();
    impl->faces.assign(faces.data_ptr<int64_t>(), faces.data_ptr<int64_t>() + faces.numel());
    impl->faces_per_hand = faces.size(0);
    if (c.hand == CaptureConfig::Hands::both) {  // the second hand's, its vertices after the first's
      for (int64_t k = 0; k < faces.numel(); ++k) impl->faces.push_back(impl->faces[k] + impl->num_vertices);
    }
  }

  std::vector<int> candidate_pose(candidates.size());
  for (size_t i = 0; i < candidates.size(); ++i)
    candidate_pose[i] = strided_pose.at(candidates[i].image->frame_idx);
  ImageSelection selection =
      select_usable_images(c, records.images_dir, candidates, candidate_pose, posed, skipped);
  std::vector<size_t>& usable = selection.usable;
  impl->monochrome_cameras = selection.monochrome;
  impl->grey_images = selection.grey_in_colour;
  if (!impl->grey_images.empty())
    spdlog::warn("{} grey image(s) (R = G = B) in colour cameras, used as they are (first: {})",
                 impl->grey_images.size(), impl->grey_images.front());
  impl->skipped = skipped;
  impl->skip_summary = make_summary(records.index_file, skipped, considered);
  if (!impl->skip_summary.empty()) spdlog::warn("{}", impl->skip_summary);
  if (!impl->monochrome_cameras.empty())
    spdlog::info("monochrome cameras: {} ({})", join(impl->monochrome_cameras, ", "),
                 c.drop_monochrome ? std::to_string(selection.dropped_monochrome) + " images dropped"
                                   : "kept");
  // A dropped camera as validation would shrink the validation set or empty it without a word.
  if (c.drop_monochrome)
    for (const auto& id : c.validation_cameras)
      if (std::count(impl->monochrome_cameras.begin(), impl->monochrome_cameras.end(), id))
        throw Error(key_name(config_key, "validation_cameras") + ": camera \"" + id +
                    "\" is monochrome and its images are dropped (" +
                    key_name(config_key, "drop_monochrome") + "); hold out a colour camera");
  if (usable.empty())
    throw Error(records.index_file + ": no usable images" +
                (records.layout == CaptureConfig::Layout::interhand ? " in capture " + std::to_string(c.capture) : "") +
                " (" + std::to_string(considered) + " considered" +
                (impl->skip_summary.empty() ? "" : "; " + impl->skip_summary) + ")");

  // Poses that still have images, in frame order; novel_pose holds out the last ones.
  std::map<int64_t, int> pose_of;
  for (size_t i : usable) pose_of.emplace(candidates[i].image->frame_idx, 0);
  int next = 0;
  for (auto& [frame, index] : pose_of) index = next++;
  impl->num_poses = next;
  if (c.split_rule == CaptureConfig::SplitRule::novel_pose && c.held_out_poses >= impl->num_poses)
    throw Error(key_name(config_key, "held_out_poses") + ": " + std::to_string(c.held_out_poses) +
                " held-out poses leave nothing to train on (the selection has " +
                std::to_string(impl->num_poses) + " poses)");
  const int first_held_out = impl->num_poses - c.held_out_poses;
  const PoseRanges pose_ranges = novel_pose_ranges(c, impl->num_poses, config_key);
  impl->posed_vertices.resize(impl->num_poses);
  for (const auto& [frame, index] : pose_of)
    impl->posed_vertices[index] = posed[strided_pose.at(frame)];

  // Frames sorted by frame index, then camera (evaluation walks them pose by pose).
  std::sort(usable.begin(), usable.end(), [&](size_t a, size_t b) {
    const auto& ia = *candidates[a].image;
    const auto& ib = *candidates[b].image;
    return std::tie(ia.frame_idx, ia.camera, ia.id) < std::tie(ib.frame_idx, ib.camera, ib.id);
  });
  std::set<std::string> kept_cameras;
  for (size_t i : usable) {
    const int pose_index = pose_of.at(candidates[i].image->frame_idx);
    const bool held_out = c.split_rule == CaptureConfig::SplitRule::novel_pose && pose_index >= first_held_out;
    impl->frames.push_back(make_frame(candidates[i], static_cast<int64_t>(impl->frames.size()),
                                      pose_index, held_out));
    // ignore: no frame names a mask file, so everything downstream (loading, the empty-mask
    // messages) treats its mask as the posed meshes'.
    if (c.supplied_masks == CaptureConfig::SuppliedMasks::ignore) impl->frames.back().mask_path.clear();
    kept_cameras.insert(impl->frames.back().camera_id);
  }
  impl->cameras.assign(kept_cameras.begin(), kept_cameras.end());

  split_frames(impl->frames, c.split_rule, cams.train, cams.test, pose_ranges, impl->train,
               impl->test);

  if (!mask_cache_dir.empty() && c.cache.disk_masks)
    impl->mask_folder = mask_folder(c, records, mask_cache_dir);
  // Lens distortion: each distorted camera's images are undistorted (K kept) when first loaded,
  // and kept as PNG files beside the masks when there is a disk cache.
  for (const auto& [name, record] : records.cameras) {
    if (!record.distortion.any() || !kept_cameras.count(name)) continue;
    Camera sized = record.camera;
    for (const FrameInfo& f : impl->frames)
      if (f.camera_id == name) {
        sized = f.camera;
        break;
      }
    UndistortMaps maps = undistort_maps(sized, record.distortion);
    if (const std::string problem = distortion_problem(sized, record.distortion, maps); !problem.empty()) {
      std::string values;
      for (const double c : record.distortion.coefficients) values += (values.empty() ? "" : ", ") + fmt::format("{}", c);
      throw Error(records.index_file + ": camera " + name + ": " + problem +
                  "; check its distortion coefficients (k1, k2, p1, p2, k3 = " + values + ")");
    }
    impl->undistort[name] = std::move(maps);
  }
  if (!impl->undistort.empty() && !mask_cache_dir.empty())
    impl->undistorted_folder = undistorted_folder(records, mask_cache_dir);
  if (!impl->undistort.empty())
    spdlog::info("{} camera(s) with lens distortion: images undistorted on first load, K kept",
                 impl->undistort.size());
  spdlog::info("{}: {} images, {} poses, {} cameras; train {}, test {} ({})",
               records.layout == CaptureConfig::Layout::interhand
                   ? "capture " + std::to_string(c.capture) + " (" + c.split + ")"
                   : layout_name(records.layout) + " capture " + c.root,
               impl->frames.size(), impl->num_poses, impl->cameras.size(),
               impl->train.size(), impl->test.size(), split_rule_name(c.split_rule));
  impl->start_workers(c.cache.prefetch_threads);
  return Capture(std::move(impl));
}

const CaptureConfig& Capture::config() const { return impl_->config; }
CaptureConfig::Layout Capture::layout() const { return impl_->layout; }
std::string Capture::region_subfolder() const {
  return impl_->layout == CaptureConfig::Layout::interhand ? impl_->config.split : std::string();
}
const std::vector<FrameInfo>& Capture::frames() const { return impl_->frames; }
const std::vector<FrameInfo>& Capture::train() const { return impl_->train; }
const std::vector<FrameInfo>& Capture::test() const { return impl_->test; }
int Capture::num_poses() const { return impl_->num_poses; }
std::vector<std::string> Capture::cameras() const { return impl_->cameras; }
std::vector<std::string> Capture::monochrome_cameras() const { return impl_->monochrome_cameras; }
const std::vector<std::string>& Capture::grey_images() const { return impl_->grey_images; }
const std::vector<SkippedImage>& Capture::skipped() const { return impl_->skipped; }
const std::string& Capture::skip_summary() const { return impl_->skip_summary; }
const std::vector<float>& Capture::posed_vertices(int pose_index) const {
  require(pose_index >= 0 && pose_index < impl_->num_poses,
          "Capture::posed_vertices: pose index " + std::to_string(pose_index) + " out of range");
  return impl_->posed_vertices[pose_index];
}
const std::vector<int64_t>& Capture::faces() const { return impl_->faces; }
int64_t Capture::num_faces(int pose_index) const { return impl_->num_faces(pose_index); }
const CropCache& Capture::cache() const { return impl_->cache; }
std::string Capture::mask_cache_folder() const { return impl_->mask_folder; }

}  // namespace handscs
