#include "data/capture_identity.h"

#include <array>
#include <string>

#include "core/error.h"
#include "core/hash.h"

namespace handscs {

namespace {

// Appends the bytes of `value` (plain numbers and arrays of them) to a frame's hashed text.
template <class T>
void append_bytes(std::string& text, const T& value) {
  text.append(reinterpret_cast<const char*>(&value), sizeof(value));
}

uint64_t frame_calibration(const FrameInfo& frame) {
  std::string text = frame.camera_id + '\0';
  append_bytes(text, frame.camera.K);
  append_bytes(text, frame.camera.R);
  append_bytes(text, frame.camera.t);
  append_bytes(text, frame.camera.width);
  append_bytes(text, frame.camera.height);
  return fnv1a64(text);
}

void append_hand(std::string& text, const HandParams& hand, bool parameters_read) {
  append_bytes(text, hand.joints);
  append_bytes(text, hand.joint_valid);
  if (!parameters_read) return;  // fitted to the joints: a product of this build, not of the files
  append_bytes(text, hand.pose);
  append_bytes(text, hand.shape);
  append_bytes(text, hand.trans);
}

uint64_t frame_annotations(const FrameInfo& frame, bool parameters_read) {
  std::string text = frame.file_name + '\0';
  bool two_hands = false;
  for (int side = 0; side < 2; ++side)
    if (const auto& hand = frame.hands[side]) {
      two_hands = true;
      text += side == 0 ? 'R' : 'L';
      append_hand(text, *hand, parameters_read);
    }
  if (!two_hands)
    append_hand(text, own_hand(frame), parameters_read);
  return fnv1a64(text);
}

uint64_t hash_field(const nlohmann::json& object, const char* key, const std::string& where) {
  const auto it = object.find(key);
  require(it != object.end() && it->is_string() && it->get_ref<const std::string&>().size() == 16,
          where + "." + key + ": expected 16 hex digits");
  const std::string& text = it->get_ref<const std::string&>();
  require(text.find_first_not_of("0123456789abcdef") == std::string::npos,
          where + "." + key + ": expected 16 hex digits, got \"" + text + "\"");
  return std::stoull(text, nullptr, 16);
}

}  // namespace

nlohmann::json CaptureIdentity::to_json() const {
  return {{"frames", frames}, {"calibration", hex16(calibration)}, {"annotations", hex16(annotations)}};
}

CaptureIdentity CaptureIdentity::from_json(const nlohmann::json& object, const std::string& where) {
  require(object.is_object(), where + ": expected an object");
  const auto count = object.find("frames");
  require(count != object.end() && count->is_number_integer() && count->get<int64_t>() >= 0,
          where + ".frames: expected a non-negative integer");
  CaptureIdentity identity;
  identity.frames = count->get<int64_t>();
  identity.calibration = hash_field(object, "calibration", where);
  identity.annotations = hash_field(object, "annotations", where);
  return identity;
}

CaptureIdentity capture_identity(const Capture& capture, const std::vector<FrameInfo>& frames) {
  const bool parameters_read = capture.config().pose_source == CaptureConfig::PoseSource::mano;
  CaptureIdentity identity;
  for (const FrameInfo& frame : frames) {
    ++identity.frames;
    // Sums wrap modulo 2^64: the order the frames come in does not matter.
    identity.calibration += frame_calibration(frame);
    identity.annotations += frame_annotations(frame, parameters_read);
  }
  return identity;
}

std::vector<std::string> identity_differences(const CaptureIdentity& run, const CaptureIdentity& given) {
  std::vector<std::string> out;
  if (run.frames != given.frames)
    out.push_back(std::to_string(given.frames) + " usable frames (the run's capture: " +
                  std::to_string(run.frames) + ")");
  if (run.calibration != given.calibration) out.push_back("the cameras' calibration");
  if (run.annotations != given.annotations) out.push_back("the image names or the annotated hands");
  return out;
}

}  // namespace handscs
