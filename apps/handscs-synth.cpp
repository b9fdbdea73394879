// handscs-synth: writes a synthetic capture of the built-in hand in the InterHand2.6M layout.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <cstdio>

#include "core/cli.h"
#include "core/config.h"
#include "synth/capture.h"

int main(int argc, char** argv) {
  CLI::App app{
      "handscs-synth: render a synthetic InterHand2.6M-layout capture of the built-in hand.\n"
      "Easy presets (the avatar's own rig under fixed light): tiny, demo, bench, paper.\n"
      "Realistic presets (tissue, fit error, flexion creases, cast shadows, gestures, forearm,\n"
      "camera response, region masks): real_tiny, real_demo, real_bench, real_paper. Switch one\n"
      "effect off with e.g. --set effects.cast_shadows=false (keys: docs/CONFIG.md, section\n"
      "handscs-synth)."};
  handscs::CommonOptions common;
  handscs::add_common_options(app, common, true);
  std::string preset = "tiny", out;
  int64_t seed = 1;
  app.add_option("--preset", preset,
                 "tiny (4 cameras x 12 frames), demo (12 x 100), bench (24 x 150), paper (30 x 400: "
                 "the paper's scale), or real_tiny, real_demo, real_bench, real_paper (same "
                 "sizes, every realistic effect on)")
      ->capture_default_str();
  app.add_option("--out", out, "output folder (gets images/, annotations/, regions/, synth.json)")
      ->required();
  app.add_option("--seed", seed, "seed of the motion, cameras, shape and noise")
      ->capture_default_str();
  // A callback so that it answers before --out is required (like --help).
  app.add_flag_callback(
      "--print-docs",
      [] {
        handscs::SynthConfig defaults = handscs::synth_preset("tiny");
        std::printf("%s", handscs::config_markdown(defaults).c_str());
        throw CLI::Success();
      },
      "print every --set key (defaults of the tiny preset) as a Markdown table and exit");
  CLI11_PARSE(app, argc, argv);
  try {
    handscs::start_up(common, "handscs-synth");
    handscs::SynthConfig config = handscs::synth_preset(preset);
    config.seed = seed;
    config = handscs::apply_synth_overrides(config, common.overrides);
    handscs::generate_synth_capture(config, out);
  } catch (const std::exception& e) {
    spdlog::error("{}", handscs::error_text(e));
    return 1;
  }
  return 0;
}
