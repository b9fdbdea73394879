#include "data/neus_capture.h"

#include <filesystem>
#include <map>

#include "core/config.h"
#include "core/error.h"
#include "data/handscs_capture.h"
#include "data/json_view.h"
#include "data/neus_cameras.h"

namespace handscs {

namespace fs = std::filesystem;

namespace {

// Each hand's translation must lie in front of every camera. A world_mat_i with one negative focal
// length decomposes into a camera turned around (the same pixels, negative depths): only the
// scene's side tells. MANO's root joint sits within ~0.1 m of trans, cameras stand further off.
void check_hands_in_front(const CaptureRecords& records, const std::string& hands_file) {
  for (const auto& [frame, record] : records.frames)
    for (const auto& [side, hand] : {std::pair{"right", &record.right}, {"left", &record.left}}) {
      if (!*hand) continue;
      const auto& x = (*hand)->mano.trans;
      for (const auto& [id, camera] : records.cameras) {
        const auto& R = camera.camera.R;
        const double depth = R[6] * x[0] + R[7] * x[1] + R[8] * x[2] + camera.camera.t[2];
        if (!(depth > 0.0))
          throw Error(camera.where + ": frame " + std::to_string(frame) + "'s " + side + " hand (trans of " +
                      hands_file + ") lies behind camera " + id + " (depth " + std::to_string(depth) +
                      "): the matrix has a negative focal length or is not this capture's");
      }
    }
}

}  // namespace

CaptureRecords read_neus_capture(const CaptureConfig& c, const std::string& prefix) {
  const std::string hands_key = prefix + ".hands_file";
  const std::map<int64_t, std::string> folders = neus_frame_folders(c.root);
  std::map<int64_t, NeusViews> views;
  for (const auto& [frame, folder] : folders) views[frame] = read_neus_views(c.root, folder);
  const std::string& archive = views.begin()->second.archive;
  if (c.hands_file.empty())
    throw Error(hands_key + ": not set, and the neus layout of " + c.root +
                " has no hand poses: fit them with `handscs-fit --multiview " + c.root +
                " --out DIR`, then set " + hands_key + "=DIR/capture.json");
  std::error_code ec;
  if (!fs::is_regular_file(c.hands_file, ec))
    throw Error(c.hands_file + ": missing or not a file (" + hands_key + ")");
  const json document = parse_json_file(c.hands_file);
  const JsonView top(document, c.hands_file, "");
  // capture.json as handscs-fit writes it is accepted whole; its cameras are the archive's own.
  top.require_known_keys({"format", "version", "flat_hand_mean", "cameras", "frames"});
  check_capture_header(top, false, c.flat_hand_mean, prefix + ".flat_hand_mean");

  CaptureRecords records;
  records.layout = CaptureConfig::Layout::neus;
  records.images_dir = c.root;
  records.index_file = archive;
  records.scope = c.root;
  records.source_files = {archive, c.hands_file};
  const JsonView frames = top.at("frames");
  std::map<int64_t, CaptureFrameEntry> entries;
  for (CaptureFrameEntry& entry : read_capture_frames(frames)) {
    if (!folders.count(entry.frame))
      frames.fail("frame " + std::to_string(entry.frame) + ": " + c.root + " (neus layout) " +
                  (folders.begin()->second == c.root ? std::string("holds one instant, frame 0")
                                                     : "has no folder of that frame (<frame>/img/)"));
    records.frames[entry.frame] = entry.record;
    entries.emplace(entry.frame, std::move(entry));
  }
  for (const auto& [frame, frame_views] : views) {
    const auto entry = entries.find(frame);  // a frame without hands is skipped by Capture::open
    for (const NeusView& view : frame_views.views) {
      const std::string id = "view" + view.name;
      records.cameras.emplace(id, RecordCamera{view.camera, LensDistortion{}, view.where});  // the first frame's
      RecordImage image;
      image.id = static_cast<int64_t>(records.images.size());
      image.file_name = fs::relative(view.image, c.root).string();
      image.mask_path = view.mask;
      image.width = view.camera.width;
      image.height = view.camera.height;
      image.camera = id;
      image.frame_idx = frame;
      if (entry != entries.end()) {
        image.seq_name = entry->second.sequence;
        image.hand_type = entry->second.hand_type;
      }
      records.images.push_back(std::move(image));
    }
  }
  check_hands_in_front(records, c.hands_file);
  return records;
}

}  // namespace handscs
