// Readers for the four InterHand2.6M annotation files (data, camera, joint_3d, MANO_NeuralAnnot),
// streamed and filtered to one capture; values stay in the file's units (mm, pixels) here.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "core/camera.h"

namespace handscs {

constexpr int kInterHandJoints = 42;  // rows of joint_3d / joint_valid: right hand 0-20, left 21-41

// One data.json `images` entry merged with its `annotations` entry (matched by image_id).
struct InterHandImage {
  int64_t id = 0;
  std::string file_name;  // relative to images/{split}/ ("Capture3/0390_dh_touchROM/cam400026/...")
  int width = 0, height = 0;
  int capture = 0;
  int subject = 0;
  std::string seq_name;
  std::string camera;  // camera id as written ("400026")
  int64_t frame_idx = 0;
  std::array<double, 4> bbox{};  // [x, y, w, h] pixels
  std::array<uint8_t, kInterHandJoints> joint_valid{};
  std::string hand_type;  // "right", "left" or "interacting"
  bool hand_type_valid = false;
};

// One camera of camera.json, as stored: X_cam = camrot (X_world - campos), campos in mm.
struct InterHandCamera {
  std::array<double, 3> campos_mm{};
  std::array<double, 9> camrot{};   // row-major
  std::array<double, 2> focal{};    // fx, fy (pixels)
  std::array<double, 2> princpt{};  // cx, cy (pixels)
};

// One frame of joint_3d.json.
struct InterHandJoints {
  std::array<double, kInterHandJoints * 3> world_mm{};  // InterHand joint order, mm
  std::array<uint8_t, kInterHandJoints> valid{};
  std::string hand_type;
  bool hand_type_valid = false;
};

// One hand of MANO_NeuralAnnot.json: pose relative to hands_mean (flat_hand_mean = false).
struct ManoParams {
  std::array<double, 48> pose{};
  std::array<double, 10> shape{};
  std::array<double, 3> trans{};  // metres
};

// One frame of MANO_NeuralAnnot.json; a null (or absent) hand entry is an empty optional.
struct InterHandMano {
  std::optional<ManoParams> right, left;
};

// Which images of data.json to keep: capture < 0 keeps all captures, empty sequences all sequences.
struct ImageFilter {
  int capture = -1;
  std::set<std::string> sequences;
};

// What data.json holds besides the filtered images, so that an empty selection can say what there
// is: every capture number, and the sequences of the filter's capture.
struct ImageCatalogue {
  std::set<int> captures;
  std::set<std::string> sequences;
};

// data.json: images (filtered) merged with their annotations, in file order. Every kept image must
// have an annotation entry. `catalogue`, when given, receives what the file holds.
std::vector<InterHandImage> read_interhand_images(const std::string& path,
                                                  const ImageFilter& filter,
                                                  ImageCatalogue* catalogue = nullptr);

// camera.json, one capture: camera id -> camera. The capture must be present.
std::map<std::string, InterHandCamera> read_interhand_cameras(const std::string& path, int capture);

// joint_3d.json, one capture: frame_idx -> joints. The capture must be present.
std::map<int64_t, InterHandJoints> read_interhand_joints(const std::string& path, int capture);

// Bounds of plausible MANO values. Shape coefficients are in standard deviations of the MANO
// shape space (NeuralAnnot fits stay within about +-3); an axis-angle beyond 2 pi is no joint
// rotation a fit produces; InterHand2.6M's hands lie within ~1 m of the capture's origin.
constexpr double kMaxManoShape = 10.0;
constexpr double kMaxManoAngle = 2.0 * 3.14159265358979323846;
constexpr double kMaxManoTranslation = 10.0;  // m

// "" when every value is within the bounds above, else the first value outside, named.
std::string mano_problem(const ManoParams& params);

// MANO_NeuralAnnot.json, one capture: frame_idx -> MANO parameters. The capture must be present.
// Implausible values (mano_problem) are errors naming the file, frame and hand.
std::map<int64_t, InterHandMano> read_interhand_mano(const std::string& path, int capture);

// camera.json entry -> library camera (metres): K from focal/princpt, R = camrot,
// t = -camrot campos / 1000 (campos is in mm).
Camera camera_from_interhand(const InterHandCamera& camera, int width, int height);

}  // namespace handscs
