#include "synth/config.h"

#include "core/config.h"
#include "core/error.h"

namespace handscs {

const ChoiceNames<CaptureConfig::Layout>& SynthConfig::layout_names() {
  using Layout = CaptureConfig::Layout;
  static const ChoiceNames<Layout> names = {
      {"interhand", Layout::interhand}, {"handscs", Layout::handscs}, {"easymocap", Layout::easymocap}};
  return names;
}

std::vector<std::string> synth_preset_names() {
  std::vector<std::string> names;
  for (const char* realism : {"", "real_"})
    for (const char* hands : {"", "both_"})
      for (const char* size : {"tiny", "demo", "bench", "paper"})
        names.push_back(std::string(realism) + hands + size);
  return names;
}

namespace {

// Every effect on: the ground truth differs from the rig as a real capture differs from MANO.
void realistic_effects(SynthEffects& e) {
  e.tissue = true;
  e.fit_error = true;
  e.flexion_skin = true;
  e.cast_shadows = true;
  e.ambient_occlusion = true;
  e.gestures = true;
  e.forearm = true;
  e.camera_response = true;
  // InterHand2.6M mixes colour and monochrome cameras; one in six here (the reader drops
  // monochrome cameras by default, data.drop_monochrome).
  e.monochrome_every = 6;
  e.region_masks = true;
}

}  // namespace

SynthConfig synth_preset(const std::string& name) {
  SynthConfig config;
  config.preset = name;
  const bool realistic = name.rfind("real_", 0) == 0;
  std::string size = realistic ? name.substr(5) : name;
  const bool both = size.rfind("both_", 0) == 0;
  if (both) size = size.substr(5);
  if (size == "tiny") {
    // CI: generates in about a second; half-size images keep the hand ~130 px tall.
    config.num_cameras = 4;
    config.num_frames = 12;
    config.num_sequences = 1;
    config.width = 167;
    config.height = 256;
    config.held_out_frames = 3;  // configs/tiny.json holds out 3 poses
  } else if (size == "demo") {
    // 100 poses: the paper's novel-pose protocol holds out the last 50, leaving 50 to train on.
    config.num_cameras = 12;
    config.num_frames = 100;
    config.num_sequences = 2;
  } else if (size == "bench") {
    config.num_cameras = 24;
    config.num_frames = 150;
    config.num_sequences = 2;
  } else if (size == "paper") {
    // The scale of the paper's InterHand2.6M captures: hundreds of training poses, and enough
    // colour cameras (30, of which every 6th is monochrome in the realistic preset: 25 colour) for
    // its novel-view protocol of 10 training and 15 test cameras. 400 poses: 350 to train on, the
    // last 50 held out as in the other presets.
    config.num_cameras = 30;
    config.num_frames = 400;
    config.num_sequences = 4;
  } else {
    std::string known;
    for (const auto& n : synth_preset_names()) known += (known.empty() ? "" : ", ") + n;
    throw Error("--preset: unknown preset \"" + name + "\" (known: " + known + ")");
  }
  if (realistic) realistic_effects(config.effects);
  if (both) {
    config.hand = CaptureConfig::Hands::both;
    // Two hands side by side are up to ~0.25 m wide; a portrait image spans 0.28 m at 1.05 m and
    // 0.36 m at 1.35 m, which keeps both inside as they drift and turn.
    config.camera_distance = 1.35;
  }
  return config;
}

SynthConfig apply_synth_overrides(const SynthConfig& config,
                                  const std::vector<std::string>& overrides) {
  SynthConfig base = config;
  json merged = config_to_json(base);
  apply_overrides(merged, overrides);
  SynthConfig out;
  config_from_json(merged, overrides.empty() ? "preset " + config.preset : "preset + --set", out);
  return out;
}

void check_synth_size(const SynthConfig& config) {
  // The whole InterHand2.6M release has 2.6M images; its largest capture ~100k poses. Every frame
  // keeps its posed mesh in memory (~20 KB), every image a few bytes of bookkeeping.
  constexpr int64_t kMaxFrames = 200000;
  constexpr int64_t kMaxImages = 5000000;
  constexpr int64_t kMaxPixels = 100000000;  // per image: the cameras' 100-megapixel limit
  const int64_t images = int64_t(config.num_cameras) * config.num_frames;
  const int64_t pixels = int64_t(config.width) * config.height;
  if (config.num_frames > kMaxFrames)
    throw Error("num_frames: " + std::to_string(config.num_frames) + " frames (at most " +
                std::to_string(kMaxFrames) + ")");
  if (images > kMaxImages)
    throw Error("num_cameras x num_frames: " + std::to_string(images) + " images (at most " +
                std::to_string(kMaxImages) + ")");
  if (pixels > kMaxPixels)
    throw Error("width x height: " + std::to_string(pixels) + " pixels per image (at most " +
                std::to_string(kMaxPixels) + ")");
}

}  // namespace handscs
