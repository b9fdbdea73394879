#include "fit/fitted_capture.h"

#include <filesystem>

#include <spdlog/spdlog.h>

#include "core/atomic_file.h"
#include "core/config.h"
#include "core/text.h"
#include "data/capture_layout.h"
#include "data/handscs_capture.h"
#include "data/json_view.h"

namespace handscs {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// Frame numbers are at most 18 digits (leading zeros aside): any longer overflows int64.
constexpr size_t kMaxFrameDigits = 18;

std::string frame_range(const FittedCaptureSource& source) {
  return std::to_string(source.frames.size()) + " frames, numbered " + std::to_string(*source.numbers.begin()) + "-" +
         std::to_string(*source.numbers.rbegin());
}

// True when `inner` is `outer` or lies inside it (both resolved as far as they exist).
bool inside(const fs::path& inner, const fs::path& outer) {
  auto resolved = [](const fs::path& p) {
    std::string text = fs::weakly_canonical(fs::absolute(p)).lexically_normal().string();
    while (text.size() > 1 && text.back() == '/') text.pop_back();
    return text;
  };
  const std::string a = resolved(inner), b = resolved(outer);
  return a == b || a.rfind(b + "/", 0) == 0;
}

}  // namespace

FittedCaptureSource read_fitted_capture_source(const std::string& root, const std::string& out) {
  FittedCaptureSource source;
  source.root = root;
  source.layout = detect_capture_layout(root, CaptureConfig::Layout::automatic, "--capture-dir");
  if (source.layout != CaptureConfig::Layout::handscs && source.layout != CaptureConfig::Layout::easymocap)
    throw Error(root + ": holds no " + kHandscsCaptureFile + " (--capture-dir takes a capture in the project's or "
                "EasyMocap's layout, docs/CAPTURE_FORMAT.md; its frames may carry no hands)");
  if (!out.empty() && inside(root, out))
    throw Error("--capture-dir " + root + " lies inside --out " + out +
                ", which the fit replaces: the written capture would link into what it removes");
  const std::string path = (fs::path(root) / kHandscsCaptureFile).string();
  std::error_code ec;
  if (!fs::is_regular_file(path, ec))
    throw Error(path + ": missing (the " + layout_name(source.layout) + " layout lists its frames there; "
                "docs/CAPTURE_FORMAT.md)");
  const json document = parse_json_file(path);
  const JsonView top(document, path, "");
  // The reader checks every camera, image folder and frame; the file's own flat_hand_mean is the
  // one to check against, since the hands it holds (if any) are replaced.
  const bool file_flat = top.at("flat_hand_mean").flag();
  read_handscs_capture(root, source.layout, file_flat, path + ": flat_hand_mean");
  if (source.layout == CaptureConfig::Layout::handscs) source.cameras = document.at("cameras");
  for (const CaptureFrameEntry& entry : read_capture_frames(top.at("frames"))) {
    source.frames.push_back({entry.frame, entry.sequence});
    source.numbers.insert(entry.frame);
  }
  std::vector<std::string> names = {"images", "masks", "regions"};
  if (source.layout == CaptureConfig::Layout::easymocap)
    names.insert(names.end(), {kEasyMocapIntrinsicsFile, kEasyMocapExtrinsicsFile});
  for (const std::string& name : names) {
    const fs::path from = fs::path(root) / name;
    if (!fs::exists(fs::symlink_status(from, ec))) continue;
    const fs::path target = fs::canonical(from, ec);
    if (ec) throw Error(from.string() + ": cannot be resolved (" + ec.message() + "); the written capture links to it");
    source.links.emplace_back(name, target.string());
  }
  return source;
}

int64_t capture_frame_of(const std::string& name, const FittedCaptureSource& source,
                         const std::string& keypoint_file) {
  const size_t first = name.find_first_not_of('0');
  const std::string significant = first == std::string::npos ? "0" : name.substr(first);
  if (name.empty() || !all_digits(name, name.size()) || !all_digits(significant, kMaxFrameDigits))
    throw Error(keypoint_file + ": frame \"" + name + "\": with --capture-dir, a frame's name is its frame number in " +
                source.root + " (\"000042\" or \"42\")");
  const int64_t frame = std::stoll(significant);
  if (!source.numbers.count(frame))
    throw Error(keypoint_file + ": frame \"" + name + "\" is not a frame of " +
                (fs::path(source.root) / kHandscsCaptureFile).string() + " (" + frame_range(source) + ")");
  return frame;
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
  for (const auto& [name, target] : source.links) fs::create_symlink(target, fs::path(out) / name);
}

}  // namespace handscs
