#include "fit/fitted_capture.h"

#include <filesystem>
#include <set>

#include <spdlog/spdlog.h>

#include "core/atomic_file.h"
#include "core/config.h"
#include "data/capture_layout.h"
#include "data/handscs_capture.h"
#include "data/json_view.h"

namespace handscs {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// Frame numbers are at most 18 digits: any longer name overflows int64 and names no real frame.
constexpr size_t kMaxFrameDigits = 18;

std::string frame_range(const FittedCaptureSource& source) {
  int64_t lo = source.frames.front().frame, hi = lo;
  for (const auto& f : source.frames) {
    lo = std::min(lo, f.frame);
    hi = std::max(hi, f.frame);
  }
  return std::to_string(source.frames.size()) + " frames, numbered " + std::to_string(lo) + "-" + std::to_string(hi);
}

// A link at `out/name` to `source/name`, when the source has it.
void link_if_present(const std::string& source, const std::string& out, const std::string& name) {
  std::error_code ec;
  const fs::path from = fs::path(source) / name;
  if (!fs::exists(fs::symlink_status(from, ec))) return;
  fs::create_symlink(fs::canonical(from), fs::path(out) / name);
}

}  // namespace

FittedCaptureSource read_fitted_capture_source(const std::string& root) {
  std::error_code ec;
  if (!fs::is_directory(root, ec)) throw Error(root + ": not a folder (--capture-dir: a capture in the project's layout)");
  FittedCaptureSource source;
  source.root = root;
  source.layout = detect_capture_layout(root, CaptureConfig::Layout::automatic, "--capture-dir");
  if (source.layout != CaptureConfig::Layout::handscs && source.layout != CaptureConfig::Layout::easymocap)
    throw Error(root + ": holds no " + kHandscsCaptureFile + " (--capture-dir takes a capture in the project's or "
                "EasyMocap's layout, docs/CAPTURE_FORMAT.md; its frames may carry no hands)");
  const std::string path = (fs::path(root) / kHandscsCaptureFile).string();
  const json document = parse_json_file(path);
  const JsonView top(document, path, "");
  // The reader checks every camera, image folder and frame; the file's own flat_hand_mean is the
  // one to check against, since the hands it holds (if any) are replaced.
  const bool file_flat = top.at("flat_hand_mean").flag();
  read_handscs_capture(root, source.layout, file_flat, path + ": flat_hand_mean");
  if (source.layout == CaptureConfig::Layout::handscs) source.cameras = document.at("cameras");
  for (const CaptureFrameEntry& entry : read_capture_frames(top.at("frames")))
    source.frames.push_back({entry.frame, entry.sequence});
  return source;
}

int64_t capture_frame_of(const std::string& name, const FittedCaptureSource& source,
                         const std::string& keypoint_file) {
  const bool digits = !name.empty() && name.size() <= kMaxFrameDigits &&
                      name.find_first_not_of("0123456789") == std::string::npos;
  if (!digits)
    throw Error(keypoint_file + ": frame \"" + name + "\": with --capture-dir, a frame's name is its frame number in " +
                source.root + " (\"000042\" or \"42\")");
  const int64_t frame = std::stoll(name);
  for (const auto& f : source.frames)
    if (f.frame == frame) return frame;
  throw Error(keypoint_file + ": frame \"" + name + "\" is not a frame of " +
              (fs::path(source.root) / kHandscsCaptureFile).string() + " (" + frame_range(source) + ")");
}

void write_fitted_capture(const FittedCaptureSource& source, const std::string& out, bool flat_hand_mean,
                          const std::map<int64_t, std::array<json, 2>>& hands) {
  json frames = json::array();
  int without_hands = 0;
  for (const auto& f : source.frames) {
    json entry = {{"frame", f.frame}};
    if (!f.sequence.empty()) entry["sequence"] = f.sequence;
    const auto it = hands.find(f.frame);
    const bool right = it != hands.end() && !it->second[0].is_null();
    const bool left = it != hands.end() && !it->second[1].is_null();
    if (right || left) entry["hand_type"] = right && left ? "interacting" : right ? "right" : "left";
    entry["right"] = right ? it->second[0] : json(nullptr);
    entry["left"] = left ? it->second[1] : json(nullptr);
    without_hands += !right && !left;
    frames.push_back(entry);
  }
  if (without_hands)
    spdlog::warn("{}: {} of {} frames have no fitted hand (no keypoints, or skipped: report.json says which); "
                 "training skips them", source.root, without_hands, source.frames.size());
  json capture = {{"format", kHandscsCaptureFormat}, {"version", kHandscsCaptureVersion},
                  {"flat_hand_mean", flat_hand_mean}};
  if (source.layout == CaptureConfig::Layout::handscs) capture["cameras"] = source.cameras;
  capture["frames"] = frames;
  write_file_atomic((fs::path(out) / kHandscsCaptureFile).string(), capture.dump(1) + "\n");
  for (const char* name : {"images", "masks", "regions"}) link_if_present(source.root, out, name);
  if (source.layout == CaptureConfig::Layout::easymocap)
    for (const char* name : {kEasyMocapIntrinsicsFile, kEasyMocapExtrinsicsFile}) link_if_present(source.root, out, name);
}

}  // namespace handscs
