#include "data/interhand_annotations.h"

#include <cmath>
#include <filesystem>
#include <functional>
#include <unordered_map>
#include <unordered_set>

#include "core/camera_checks.h"
#include "core/error.h"
#include "core/text.h"
#include "data/json_view.h"

namespace handscs {

using json = nlohmann::json;

namespace {

// The annotation half of an image, kept compactly until both arrays are read.
struct ImageAnnotation {
  std::array<double, 4> bbox{};
  std::array<uint8_t, kInterHandJoints> joint_valid{};
  std::string hand_type;
  bool hand_type_valid = false;
};

// Checks that the top level is an object holding `key` (after streaming, its value is emptied).
void require_top_key(const json& skeleton, const std::string& path, const std::string& key) {
  JsonView top(skeleton, path, "");
  top.require_object();
  if (!skeleton.contains(key)) top.fail("missing key \"" + key + "\"");
}

int64_t frame_key(const JsonElement& element, const std::string& path) {
  const std::string& key = element.second;
  size_t used = 0;
  int64_t frame = -1;
  try {
    frame = std::stoll(key, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != key.size())
    throw Error(path + ": " + element.top + "." + key + ": frame key is not an integer");
  return frame;
}

void require_object_member(const JsonElement& element, const std::string& path) {
  if (element.in_array) throw Error(path + ": " + element.top + ": expected object, got array");
}

// True for a relative path none of whose components is "..": joined to the images folder it
// stays inside it (InterHand2.6M's file_name is "Capture0/<seq>/cam<id>/image<frame>.jpg").
bool is_contained_relative_path(const std::string& file_name) {
  const std::filesystem::path path(file_name);
  if (file_name.empty() || path.is_absolute() || path.has_root_name()) return false;
  for (const auto& part : path)
    if (part == "..") return false;
  return true;
}

}  // namespace

std::vector<InterHandImage> read_interhand_images(const std::string& path,
                                                  const ImageFilter& filter,
                                                  ImageCatalogue* catalogue) {
  std::vector<InterHandImage> images;
  std::unordered_map<int64_t, ImageAnnotation> annotations;
  std::unordered_set<int64_t> image_ids;  // of the kept images
  // When "images" precedes "annotations" (as in the release), annotations of images not kept are
  // skipped unread: at 1.4M records, holding them all until the images are known takes ~200 MB.
  bool images_seen = false, images_complete = false;
  auto keep_top = [&](const std::string& key) {
    if (key == "images") images_seen = true;
    if (key == "annotations" && images_seen) images_complete = true;
    return key == "images" || key == "annotations";
  };
  auto visit = [&](const JsonElement& element) {
    if (!element.in_array) throw Error(path + ": " + element.top + ": expected array, got object");
    JsonView item(element.value, path, element.top + "[" + element.second + "]");
    item.require_object();
    if (element.top == "images") {
      const int capture = static_cast<int>(item.at("capture").integer());
      const std::string seq = item.at("seq_name").string();
      if (catalogue) catalogue->captures.insert(capture);
      if (filter.capture >= 0 && capture != filter.capture) return;
      if (catalogue) catalogue->sequences.insert(seq);
      if (!filter.sequences.empty() && !filter.sequences.count(seq)) return;
      InterHandImage image;
      image.id = item.at("id").integer();
      if (!image_ids.insert(image.id).second)
        item.at("id").fail("duplicate image id " + std::to_string(image.id));
      image.file_name = item.at("file_name").string();
      if (!is_contained_relative_path(image.file_name))
        item.at("file_name").fail("\"" + image.file_name +
                                  "\" is not a relative path inside the images folder (absolute, or has ..)");
      image.width = static_cast<int>(item.at("width").integer());
      image.height = static_cast<int>(item.at("height").integer());
      if (image.width <= 0 || image.height <= 0)
        item.at("width").fail("image size must be positive");
      image.capture = capture;
      image.subject = static_cast<int>(item.at("subject").integer());
      image.seq_name = seq;
      image.camera = item.at("camera").string();
      image.frame_idx = item.at("frame_idx").integer();
      images.push_back(std::move(image));
    } else {
      const int64_t image_id = item.at("image_id").integer();
      if (images_complete && !image_ids.count(image_id)) return;
      ImageAnnotation annotation;
      if (annotations.count(image_id))
        item.at("image_id").fail("second annotation for image_id " + std::to_string(image_id));
      item.at("bbox").numbers(annotation.bbox.data(), 4);
      item.at("joint_valid").flags(annotation.joint_valid.data(), kInterHandJoints);
      annotation.hand_type = item.at("hand_type").string();
      annotation.hand_type_valid = item.at("hand_type_valid").flag();
      annotations[image_id] = std::move(annotation);
    }
  };
  const json skeleton = stream_json_elements(path, keep_top, visit);
  require_top_key(skeleton, path, "images");
  require_top_key(skeleton, path, "annotations");
  for (const char* key : {"images", "annotations"})
    if (!skeleton[key].is_array())
      throw Error(path + ": " + key + ": expected array, got " + json_kind(skeleton[key]));

  for (auto& image : images) {
    auto it = annotations.find(image.id);
    if (it == annotations.end())
      throw Error(path + ": annotations: no entry for image_id " + std::to_string(image.id) + " (" +
                  image.file_name + ")");
    image.bbox = it->second.bbox;
    image.joint_valid = it->second.joint_valid;
    image.hand_type = std::move(it->second.hand_type);
    image.hand_type_valid = it->second.hand_type_valid;
  }
  return images;
}

std::map<std::string, InterHandCamera> read_interhand_cameras(const std::string& path,
                                                              int capture) {
  const std::string key = std::to_string(capture);
  std::map<std::string, json> fields;  // campos/camrot/focal/princpt objects of the capture
  auto visit = [&](const JsonElement& element) {
    require_object_member(element, path);
    fields[element.second] = element.value;
  };
  const json skeleton = stream_json_elements(
      path, [&](const std::string& top) { return top == key; }, visit);
  require_top_key(skeleton, path, key);
  json entry = json::object();
  for (auto& [name, value] : fields) entry[name] = std::move(value);
  JsonView root(entry, path, key);
  if (!skeleton[key].is_object()) root.fail("expected object, got " + json_kind(skeleton[key]));
  JsonView campos = root.at("campos"), camrot = root.at("camrot"), focal = root.at("focal"),
           princpt = root.at("princpt");
  campos.require_object();
  std::map<std::string, InterHandCamera> cameras;
  for (auto it = campos.raw().begin(); it != campos.raw().end(); ++it) {
    const std::string& id = it.key();
    InterHandCamera camera;
    campos.at(id).numbers(camera.campos_mm.data(), 3);
    camrot.at(id).matrix(camera.camrot.data(), 3, 3);
    focal.at(id).numbers(camera.focal.data(), 2);
    princpt.at(id).numbers(camera.princpt.data(), 2);
    if (!(camera.focal[0] > 0 && camera.focal[1] > 0))
      focal.at(id).fail("focal lengths must be positive");
    const std::string not_rotation = rotation_problem(camera.camrot);
    if (!not_rotation.empty()) camrot.at(id).fail(not_rotation);
    cameras[id] = camera;
  }
  return cameras;
}

// Streams the per-frame elements of capture `key` of a {capture: {frame: ...}} file into `visit`;
// the capture must be present and be an object.
static void stream_capture_frames(const std::string& path, const std::string& key,
                           const std::function<void(const JsonElement&)>& visit) {
  const json skeleton = stream_json_elements(
      path, [&](const std::string& top) { return top == key; }, visit);
  require_top_key(skeleton, path, key);
  if (!skeleton[key].is_object())
    throw Error(path + ": " + key + ": expected object, got " + json_kind(skeleton[key]));
}

std::map<int64_t, InterHandJoints> read_interhand_joints(const std::string& path, int capture) {
  const std::string key = std::to_string(capture);
  std::map<int64_t, InterHandJoints> frames;
  auto visit = [&](const JsonElement& element) {
    require_object_member(element, path);
    const int64_t frame = frame_key(element, path);
    JsonView item(element.value, path, element.top + "." + element.second);
    InterHandJoints joints;
    item.at("world_coord").matrix(joints.world_mm.data(), kInterHandJoints, 3);
    item.at("joint_valid").flags(joints.valid.data(), kInterHandJoints);
    joints.hand_type = item.at("hand_type").string();
    joints.hand_type_valid = item.at("hand_type_valid").flag();
    frames[frame] = std::move(joints);
  };
  stream_capture_frames(path, key, visit);
  return frames;
}

std::string mano_problem(const ManoParams& params) {
  for (int i = 0; i < 10; ++i)
    if (std::abs(params.shape[i]) > kMaxManoShape)
      return "shape[" + std::to_string(i) + "] = " + number_text(params.shape[i]) + " is beyond +-" +
             std::to_string(static_cast<int>(kMaxManoShape)) + " standard deviations: not a hand";
  for (int joint = 0; joint < 16; ++joint) {
    const double angle = std::sqrt(params.pose[3 * joint] * params.pose[3 * joint] +
                                   params.pose[3 * joint + 1] * params.pose[3 * joint + 1] +
                                   params.pose[3 * joint + 2] * params.pose[3 * joint + 2]);
    if (angle > kMaxManoAngle)
      return "pose[" + std::to_string(3 * joint) + ".." + std::to_string(3 * joint + 2) +
             "] rotates joint " + std::to_string(joint) + " by " + number_text(angle) +
             " rad, more than 2 pi";
  }
  for (int i = 0; i < 3; ++i)
    if (std::abs(params.trans[i]) > kMaxManoTranslation)
      return "trans[" + std::to_string(i) + "] = " + number_text(params.trans[i]) + " m is more than " +
             std::to_string(static_cast<int>(kMaxManoTranslation)) + " m from the capture's origin";
  return "";
}

std::map<int64_t, InterHandMano> read_interhand_mano(const std::string& path, int capture) {
  const std::string key = std::to_string(capture);
  std::map<int64_t, InterHandMano> frames;
  auto read_hand = [&](const JsonView& frame, const char* hand) -> std::optional<ManoParams> {
    // A null hand is the normal "not annotated" marker; an absent key is read the same way.
    if (!frame.has(hand) || frame.at(hand).is_null()) return std::nullopt;
    const JsonView entry = frame.at(hand);
    ManoParams params;
    entry.at("pose").numbers(params.pose.data(), 48);
    entry.at("shape").numbers(params.shape.data(), 10);
    entry.at("trans").numbers(params.trans.data(), 3);
    const std::string implausible = mano_problem(params);
    if (!implausible.empty()) entry.fail(implausible);
    return params;
  };
  auto visit = [&](const JsonElement& element) {
    require_object_member(element, path);
    const int64_t frame = frame_key(element, path);
    JsonView item(element.value, path, element.top + "." + element.second);
    InterHandMano mano;
    if (!item.is_null()) {
      item.require_object();
      mano.right = read_hand(item, "right");
      mano.left = read_hand(item, "left");
    }
    frames[frame] = std::move(mano);
  };
  stream_capture_frames(path, key, visit);
  return frames;
}

Camera camera_from_interhand(const InterHandCamera& camera, int width, int height) {
  Camera out;
  out.K = {camera.focal[0], 0, camera.princpt[0], 0, camera.focal[1], camera.princpt[1], 0, 0, 1};
  out.R = camera.camrot;
  const double mm_to_m = 1e-3;
  for (int r = 0; r < 3; ++r) {
    double sum = 0;
    for (int c = 0; c < 3; ++c) sum += camera.camrot[r * 3 + c] * camera.campos_mm[c];
    out.t[r] = -sum * mm_to_m;
  }
  out.width = width;
  out.height = height;
  return out;
}

}  // namespace handscs
