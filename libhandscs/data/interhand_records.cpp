#include "data/interhand_records.h"

#include <set>

#include "core/error.h"
#include "core/text.h"
#include "data/annotation_cache.h"
#include "data/capture_layout.h"
#include "data/joint_pose_fit.h"
#include "hand/lbs.h"  // kInterHandFromMano21

namespace handscs {

void interhand_hand_joints(const InterHandJoints& entry, bool right, std::array<double, 63>& joints,
                           std::array<uint8_t, 21>& valid) {
  const int row0 = right ? 0 : 21;  // joint_3d rows: right hand 0-20, left 21-41
  for (int ih = 0; ih < 21; ++ih) {
    const int m = kInterHandFromMano21[ih];
    for (int d = 0; d < 3; ++d) joints[m * 3 + d] = entry.world_mm[(row0 + ih) * 3 + d] * 1e-3;
    valid[m] = entry.valid[row0 + ih];
  }
}

CaptureRecords read_interhand_records(const CaptureConfig& c, const std::string& prefix) {
  const CaptureLayout layout = resolve_capture_layout(c.root, c.split, prefix + ".root");
  const AnnotationCache annotation_cache(c.annotation_cache);
  CaptureImages capture_images = annotation_cache.images(layout.data_json, c.capture);
  const ImageCatalogue& catalogue = capture_images.catalogue;
  if (!catalogue.captures.count(c.capture)) {
    std::vector<std::string> present;
    for (int capture : catalogue.captures) present.push_back(std::to_string(capture));
    throw Error(layout.data_json + ": no images of capture " + std::to_string(c.capture) + " (" +
                prefix + ".capture); the file holds " +
                (present.empty() ? std::string("no images") : "captures " + list_text(present)));
  }
  for (const auto& seq : c.sequences)
    if (!catalogue.sequences.count(seq))
      throw Error(prefix + ".sequences: sequence \"" + seq + "\" has no images in capture " +
                  std::to_string(c.capture) + " of " + layout.data_json + "; it has " +
                  list_text({catalogue.sequences.begin(), catalogue.sequences.end()}));
  const std::map<std::string, InterHandCamera> cameras =
      read_interhand_cameras(layout.camera_json, c.capture);
  const std::map<int64_t, InterHandJoints> joints =
      annotation_cache.joints(layout.joint_3d_json, c.capture);
  const bool from_joints = c.pose_source == CaptureConfig::PoseSource::joints;
  const std::map<int64_t, InterHandMano> mano =
      from_joints ? std::map<int64_t, InterHandMano>{} : annotation_cache.mano(layout.mano_json, c.capture);

  CaptureRecords records;
  records.layout = CaptureConfig::Layout::interhand;
  records.images_dir = layout.images_dir;
  records.index_file = layout.data_json;
  records.scope = "capture " + std::to_string(c.capture) + " of " + layout.data_json;
  // The MANO file by path and stamp, the camera file by stamp: the mask cache's key as it always was.
  // With poses fitted to the joints, the joint file stands in for the MANO file.
  records.source_files = {from_joints ? layout.joint_3d_json : layout.mano_json, layout.camera_json};
  const std::set<std::string> sequences(c.sequences.begin(), c.sequences.end());
  for (auto& image : capture_images.images) {
    if (!sequences.empty() && !sequences.count(image.seq_name)) continue;
    // Every camera data.json names must be in camera.json.
    if (!cameras.count(image.camera))
      throw Error(layout.camera_json + ": " + std::to_string(c.capture) + ".campos: missing key \"" +
                  image.camera + "\" (camera of " + image.file_name + " in " + layout.data_json + ")");
    RecordImage record;
    record.id = image.id;
    record.file_name = std::move(image.file_name);
    record.width = image.width;
    record.height = image.height;
    record.capture = image.capture;
    record.seq_name = std::move(image.seq_name);
    record.camera = std::move(image.camera);
    record.frame_idx = image.frame_idx;
    record.bbox = image.bbox;
    record.hand_type = std::move(image.hand_type);
    records.images.push_back(std::move(record));
  }
  for (const auto& [id, camera] : cameras) {
    RecordCamera record;
    record.camera = camera_from_interhand(camera, 0, 0);  // size: each image's
    record.where = layout.camera_json + ": " + std::to_string(c.capture) + ": camera " + id;
    records.cameras[id] = record;
  }
  if (from_joints) {
    records.frames = fit_joint_frames(joints, layout.joint_3d_json, c);
    return records;
  }
  // A frame without a MANO entry has no hands ("null MANO"); joint_3d.json must hold every frame.
  for (const auto& [frame, params] : mano) {
    RecordFrame record;
    auto j = joints.find(frame);
    record.has_joint_entry = j != joints.end();
    for (const bool right : {true, false}) {
      const std::optional<ManoParams>& hand_params = right ? params.right : params.left;
      if (!hand_params) continue;
      RecordHand hand;
      hand.mano = *hand_params;
      if (record.has_joint_entry) {
        hand.has_joints = true;
        interhand_hand_joints(j->second, right, hand.joints, hand.joint_valid);
      }
      (right ? record.right : record.left) = hand;
    }
    records.frames[frame] = std::move(record);
  }
  return records;
}

}  // namespace handscs
