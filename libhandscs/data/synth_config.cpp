#include "data/synth_config.h"

#include "core/error.h"

namespace handscs {

std::vector<std::string> synth_preset_names() { return {"tiny", "demo", "bench"}; }

SynthConfig synth_preset(const std::string& name) {
  SynthConfig config;
  config.preset = name;
  if (name == "tiny") {
    // CI: generates in about a second; half-size images keep the hand ~130 px tall.
    config.num_cameras = 4;
    config.num_frames = 12;
    config.num_sequences = 1;
    config.width = 167;
    config.height = 256;
  } else if (name == "demo") {
    // 100 poses: the paper's novel-pose protocol holds out the last 50, leaving 50 to train on.
    config.num_cameras = 12;
    config.num_frames = 100;
    config.num_sequences = 2;
  } else if (name == "bench") {
    config.num_cameras = 24;
    config.num_frames = 150;
    config.num_sequences = 2;
  } else {
    std::string known;
    for (const auto& n : synth_preset_names()) known += (known.empty() ? "" : ", ") + n;
    throw Error("--preset: unknown preset \"" + name + "\" (known: " + known + ")");
  }
  return config;
}

}  // namespace handscs
