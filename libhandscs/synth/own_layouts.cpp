#include "synth/own_layouts.h"

#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "core/error.h"
#include "data/capture_json.h"
#include "data/capture_layout.h"
#include "data/easymocap_cameras.h"
#include "data/handscs_capture.h"
#include "synth/mirror.h"

namespace handscs {

namespace fs = std::filesystem;
using nlohmann::json;

LensDistortion synth_lens_distortion(CaptureConfig::Layout layout) {
  return layout == CaptureConfig::Layout::easymocap ? kSynthLensDistortion : LensDistortion{};
}

std::string own_layout_image_name(const SynthFrame& frame, const SynthCamera& camera) {
  return camera.id + "/" + frame_file_stem(frame.frame_idx) + ".jpg";
}

Camera written_camera(const SynthScene& scene, const SynthCamera& camera) {
  if (scene.config.hand != CaptureConfig::Hands::left) return camera.camera;
  return camera_from_interhand(mirror_interhand_camera(camera.raw, camera.camera.width),
                               camera.camera.width, camera.camera.height);
}

std::array<std::optional<WrittenHand>, 2> written_hands(const SynthScene& scene, size_t k) {
  const bool mirrored = scene.config.hand == CaptureConfig::Hands::left;
  auto written = [&](const SynthFrame& f, bool mirror) {
    WrittenHand hand;
    hand.pose = mirror ? mirror_mano_pose(f.annotated) : f.annotated;
    hand.shape = f.annotated_shape;
    hand.trans = mirror ? mirror_point(f.annotated_trans) : f.annotated_trans;
    for (int j = 0; j < 21; ++j) {
      std::array<double, 3> p = {f.joints[j * 3], f.joints[j * 3 + 1], f.joints[j * 3 + 2]};
      if (mirror) p = mirror_point(p);
      for (int d = 0; d < 3; ++d) hand.joints[j * 3 + d] = p[d];
    }
    return hand;
  };
  std::array<std::optional<WrittenHand>, 2> hands;
  hands[mirrored ? 1 : 0] = written(scene.frames.at(k), mirrored);
  if (!scene.left_frames.empty()) hands[1] = written(scene.left_frames.at(k), false);
  return hands;
}

std::string written_hand_type(const SynthScene& scene) {
  return scene.config.hand == CaptureConfig::Hands::both ? "interacting" : hand_name(scene.config.hand);
}

int64_t write_own_layout_annotations(const SynthScene& scene, const std::string& root) {
  const SynthConfig& c = scene.config;
  const bool easymocap = c.layout == CaptureConfig::Layout::easymocap;
  json document = {{"format", kHandscsCaptureFormat},
                   {"version", kHandscsCaptureVersion},
                   // As the InterHand2.6M files: poses relative to hands_mean.
                   {"flat_hand_mean", false}};
  std::map<std::string, RecordCamera> cameras;
  for (const auto& cam : scene.cameras) {
    RecordCamera record;
    record.camera = written_camera(scene, cam);
    record.distortion = synth_lens_distortion(c.layout);
    cameras[cam.id] = record;
  }
  int64_t bytes = 0;
  if (easymocap) {
    const std::string intri = (fs::path(root) / kEasyMocapIntrinsicsFile).string();
    const std::string extri = (fs::path(root) / kEasyMocapExtrinsicsFile).string();
    write_easymocap_cameras(cameras, intri, extri);
    bytes += static_cast<int64_t>(fs::file_size(intri) + fs::file_size(extri));
  } else {
    json out = json::object();
    for (const auto& [id, record] : cameras) {
      out[id] = capture_camera_json(record.camera);
    }
    document["cameras"] = out;
  }
  json frames = json::array();
  for (size_t k = 0; k < scene.frames.size(); ++k) {
    const SynthFrame& f = scene.frames[k];
    json entry = {{"frame", f.frame_idx},
                  {"sequence", f.seq_name},
                  {"hand_type", written_hand_type(scene)}};
    const auto hands = written_hands(scene, k);
    for (Handedness side : {Handedness::right, Handedness::left}) {
      const auto& hand = hands[static_cast<int>(side)];
      if (hand)
        entry[hand_name(side)] = capture_hand_json(hand->pose.data(), hand->shape.data(),
                                                   hand->trans.data(), hand->joints.data());
    }
    frames.push_back(entry);
  }
  document["frames"] = frames;
  const std::string text = document.dump();
  write_file_atomic((fs::path(root) / kHandscsCaptureFile).string(), text);
  return bytes + static_cast<int64_t>(text.size());
}

}  // namespace handscs
