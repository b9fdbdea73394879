#include "data/handscs_capture.h"

#include <cstdio>
#include <filesystem>
#include <set>

#include "core/camera_checks.h"
#include "core/config.h"
#include "core/error.h"
#include "core/image_header.h"
#include "data/capture_layout.h"
#include "data/easymocap_cameras.h"
#include "data/json_view.h"

namespace handscs {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

RecordCamera read_camera(const JsonView& entry, const std::string& path) {
  entry.require_known_keys({"K", "R", "t", "width", "height", "dist"});
  RecordCamera record;
  record.where = path + ": " + entry.path();
  Camera& camera = record.camera;
  entry.at("K").matrix(camera.K.data(), 3, 3);
  const std::string not_pinhole = pinhole_matrix_problem(camera.K);
  if (!not_pinhole.empty()) entry.at("K").fail(not_pinhole);
  entry.at("R").matrix(camera.R.data(), 3, 3);
  const std::string not_rotation = rotation_problem(camera.R);
  if (!not_rotation.empty()) entry.at("R").fail(not_rotation);
  entry.at("t").numbers(camera.t.data(), 3);
  camera.width = static_cast<int>(entry.at("width").integer());
  camera.height = static_cast<int>(entry.at("height").integer());
  if (camera.width <= 0 || camera.height <= 0) entry.at("width").fail("image size must be positive");
  if (entry.has("dist")) {
    const JsonView dist = entry.at("dist");
    const size_t n = dist.size();
    if (n != 4 && n != 5) dist.fail("expected array of 5 (k1, k2, p1, p2, k3) or 4, got " + json_kind(dist.raw()));
    dist.numbers(record.distortion.coefficients.data(), n);
  }
  return record;
}

std::optional<RecordHand> read_hand(const JsonView& frame, const char* side) {
  if (!frame.has(side) || frame.at(side).is_null()) return std::nullopt;
  const JsonView entry = frame.at(side);
  entry.require_known_keys({"pose", "shape", "trans", "joints"});
  RecordHand hand;
  entry.at("pose").numbers(hand.mano.pose.data(), 48);
  entry.at("shape").numbers(hand.mano.shape.data(), 10);
  entry.at("trans").numbers(hand.mano.trans.data(), 3);
  const std::string implausible = mano_problem(hand.mano);
  if (!implausible.empty()) entry.fail(implausible);
  if (entry.has("joints")) {
    entry.at("joints").matrix(hand.joints.data(), 21, 3);
    hand.has_joints = true;
    hand.joint_valid.fill(1);
  }
  return hand;
}

// The image of `camera` at `stem`: .jpg, else .png when only that exists (a missing image keeps
// .jpg and is skipped as missing by Capture::open).
std::string image_name(const fs::path& images_dir, const std::string& camera, const std::string& stem) {
  const std::string jpg = camera + "/" + stem + ".jpg", png = camera + "/" + stem + ".png";
  std::error_code ec;
  if (!fs::exists(images_dir / jpg, ec) && fs::exists(images_dir / png, ec)) return png;
  return jpg;
}

// Width and height of an image from its header (0 x 0 when it cannot be read, is not a regular
// file, or states more pixels than a camera may have). Read through a checked descriptor: a named
// pipe in the image's place is not waited on (Capture::open skips it as "not a file").
std::pair<int, int> header_size(const std::string& path) {
  std::string bytes;
  try {
    bytes = read_image_bytes(path);
  } catch (const Error&) {
    return {0, 0};
  }
  const ImageHeaderSize size = image_header_size(bytes);
  if (!size.known) return {0, 0};
  return {static_cast<int>(size.width), static_cast<int>(size.height)};
}

}  // namespace

std::string frame_file_stem(int64_t frame) {
  char stem[32];
  std::snprintf(stem, sizeof(stem), "%06lld", static_cast<long long>(frame));
  return stem;
}

void check_capture_header(const JsonView& top, bool required, bool flat_hand_mean,
                          const std::string& flat_key) {
  if (required || top.has("format")) {
    const std::string format = top.at("format").string();
    if (format != kHandscsCaptureFormat)
      top.at("format").fail("expected \"" + std::string(kHandscsCaptureFormat) + "\", got \"" + format + "\"");
  }
  if (required || top.has("version")) {
    const int64_t version = top.at("version").integer();
    if (version != kHandscsCaptureVersion)
      top.at("version").fail("version " + std::to_string(version) + " is not one this build reads (it reads " +
                             std::to_string(kHandscsCaptureVersion) + ")");
  }
  if (required || top.has("flat_hand_mean")) {
    const bool file_flat = top.at("flat_hand_mean").flag();
    if (file_flat != flat_hand_mean)
      top.at("flat_hand_mean").fail(std::string("poses are stored with flat_hand_mean ") +
                                    (file_flat ? "true" : "false") + " but " + flat_key + " is " +
                                    (flat_hand_mean ? "true" : "false") + " (set it to match)");
  }
}

std::vector<CaptureFrameEntry> read_capture_frames(const JsonView& frames) {
  const size_t num_frames = frames.size();
  if (num_frames == 0) frames.fail("no frames");
  std::vector<CaptureFrameEntry> out;
  std::set<int64_t> seen;
  for (size_t k = 0; k < num_frames; ++k) {
    const JsonView entry = frames.at(k);
    entry.require_known_keys({"frame", "sequence", "hand_type", "right", "left"});
    CaptureFrameEntry e;
    e.frame = entry.at("frame").integer();
    if (e.frame < 0) entry.at("frame").fail("frame numbers must be >= 0");
    if (!seen.insert(e.frame).second) entry.at("frame").fail("frame " + std::to_string(e.frame) + " appears twice");
    e.record.right = read_hand(entry, "right");
    e.record.left = read_hand(entry, "left");
    if (entry.has("hand_type")) {
      e.hand_type = entry.at("hand_type").string();
      if (e.hand_type != "right" && e.hand_type != "left" && e.hand_type != "interacting")
        entry.at("hand_type").fail("expected \"right\", \"left\" or \"interacting\", got \"" + e.hand_type + "\"");
    }
    e.sequence = entry.has("sequence") ? entry.at("sequence").string() : "";
    out.push_back(std::move(e));
  }
  return out;
}

CaptureRecords read_handscs_capture(const std::string& root, CaptureConfig::Layout layout,
                                    bool flat_hand_mean, const std::string& flat_key) {
  const fs::path base(root);
  const bool easymocap = layout == CaptureConfig::Layout::easymocap;
  CaptureRecords records;
  records.layout = layout;
  records.images_dir = (base / "images").string();
  const std::string path = (base / kHandscsCaptureFile).string();
  records.index_file = path;
  records.scope = path;
  std::error_code ec;
  if (!fs::is_regular_file(path, ec))
    throw Error(path + ": missing (the " + layout_name(layout) + " layout keeps its frames' MANO parameters "
                "there; docs/CAPTURE_FORMAT.md)");
  const json document = parse_json_file(path);
  const JsonView top(document, path, "");
  if (easymocap)
    top.require_known_keys({"format", "version", "flat_hand_mean", "frames"});
  else
    top.require_known_keys({"format", "version", "flat_hand_mean", "cameras", "frames"});
  check_capture_header(top, true, flat_hand_mean, flat_key);

  if (easymocap) {
    const std::string intri = (base / kEasyMocapIntrinsicsFile).string();
    const std::string extri = (base / kEasyMocapExtrinsicsFile).string();
    if (!fs::is_regular_file(extri, ec)) throw Error(extri + ": missing (the easymocap layout needs it beside " + intri + ")");
    records.cameras = read_easymocap_cameras(intri, extri);
    records.source_files = {path, intri, extri};
  } else {
    const JsonView cameras = top.at("cameras");
    cameras.require_object();
    if (cameras.raw().empty()) cameras.fail("no cameras");
    for (auto it = cameras.raw().begin(); it != cameras.raw().end(); ++it)
      records.cameras[it.key()] = read_camera(cameras.at(it.key()), path);
    records.source_files = {path};
  }
  for (const auto& [name, camera] : records.cameras) {
    const fs::path folder = base / "images" / name;
    if (!fs::is_directory(folder, ec))
      throw Error(folder.string() + ": missing image folder of camera \"" + name + "\" (" +
                  (easymocap ? "names in " + (base / kEasyMocapIntrinsicsFile).string()
                             : "cameras." + name + " in " + path) +
                  ")");
  }

  const fs::path masks_dir = base / "masks";
  const bool has_masks = fs::is_directory(masks_dir, ec);
  if (!has_masks && fs::exists(fs::symlink_status(masks_dir, ec)))
    throw Error(masks_dir.string() + ": not a folder; supplied masks go in masks/<camera>/<frame>.png "
                "(remove it to use the posed meshes' masks)");
  for (const CaptureFrameEntry& entry : read_capture_frames(top.at("frames"))) {
    const int64_t frame = entry.frame;
    records.frames[frame] = entry.record;
    const std::string stem = frame_file_stem(frame);
    for (const auto& [name, camera] : records.cameras) {
      RecordImage image;
      image.id = static_cast<int64_t>(records.images.size());
      image.file_name = image_name(base / "images", name, stem);
      if (has_masks) {
        const fs::path mask = masks_dir / name / (stem + ".png");
        // Anything at the mask's name is the mask: a named pipe or a folder there is refused by
        // name when the frame loads, not passed over for the posed mesh's mask.
        if (fs::exists(fs::symlink_status(mask, ec))) image.mask_path = mask.string();
      }
      image.width = camera.camera.width;
      image.height = camera.camera.height;
      image.seq_name = entry.sequence;
      image.camera = name;
      image.frame_idx = frame;
      image.hand_type = entry.hand_type;
      records.images.push_back(std::move(image));
    }
  }

  // EasyMocap's intri.yml may omit the image size (H_, W_): the camera's first image states it.
  for (auto& [name, camera] : records.cameras) {
    if (camera.camera.width > 0) continue;
    for (const RecordImage& image : records.images) {
      if (image.camera != name) continue;
      const auto [w, h] = header_size((fs::path(records.images_dir) / image.file_name).string());
      if (w > 0 && h > 0) {
        camera.camera.width = w;
        camera.camera.height = h;
        break;
      }
    }
    if (camera.camera.width == 0)
      throw Error((base / "images" / name).string() + ": no readable image states camera \"" + name +
                  "\"'s size (" + (base / kEasyMocapIntrinsicsFile).string() + " has no H_" + name +
                  ", W_" + name + ")");
    for (RecordImage& image : records.images)
      if (image.camera == name) {
        image.width = camera.camera.width;
        image.height = camera.camera.height;
      }
  }
  return records;
}

}  // namespace handscs
