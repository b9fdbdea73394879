#include "synth/synth_command.h"

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <cstdio>

#include "core/cli.h"
#include "core/config.h"
#include "synth/capture.h"

namespace handscs {

int synth_command(int argc, char** argv) {
  CLI::App app{
      "handscs-synth: render a synthetic capture of the built-in hand in InterHand2.6M's layout,\n"
      "the project's own (--layout handscs) or EasyMocap's (--layout easymocap, with a known\n"
      "lens distortion; docs/CAPTURE_FORMAT.md).\n"
      "Easy presets (the avatar's own rig under fixed light): tiny, demo, bench, paper.\n"
      "Realistic presets (tissue, fit error, flexion creases, cast shadows, gestures, forearm,\n"
      "camera response, region masks): real_tiny, real_demo, real_bench, real_paper. Switch one\n"
      "effect off with e.g. --set effects.cast_shadows=false (keys: docs/CONFIG.md, section\n"
      "handscs-synth)."};
  CommonOptions common;
  add_common_options(app, common, true);
  std::string preset = "tiny", out, layout;
  int64_t seed = 1;
  bool overwrite = false;
  app.add_option("--preset", preset,
                 "tiny (4 cameras x 12 frames), demo (12 x 100), bench (24 x 150), paper (30 x 400: "
                 "the paper's scale), or real_tiny, real_demo, real_bench, real_paper (same "
                 "sizes, every realistic effect on)")
      ->capture_default_str();
  app.add_option("--out", out, "output folder (gets images/, annotations/, regions/, synth.json)")
      ->required();
  app.add_option("--layout", layout,
                 "files written: interhand (default), handscs or easymocap (same as --set layout=...)")
      ->check(CLI::IsMember({"interhand", "handscs", "easymocap"}));
  app.add_option("--seed", seed, "seed of the motion, cameras, shape and noise")
      ->capture_default_str();
  app.add_flag("--overwrite", overwrite,
               "replace OUT when it is not empty (the new capture is written beside it and swapped "
               "in when complete)");
  // A callback so that it answers before --out is required (like --help).
  app.add_flag_callback(
      "--print-docs",
      [] {
        SynthConfig defaults = synth_preset("tiny");
        std::printf("%s", config_markdown(defaults).c_str());
        throw CLI::Success();
      },
      "print every --set key (defaults of the tiny preset) as a Markdown table and exit");
  CLI11_PARSE(app, argc, argv);
  try {
    start_up(common, "handscs-synth");
    SynthConfig config = synth_preset(preset);
    config.seed = seed;
    config = apply_synth_overrides(config, common.overrides);
    if (!layout.empty()) config.layout = choice_value(layout, SynthConfig::layout_names());
    generate_synth_capture(config, out, overwrite);
  } catch (const std::exception& e) {
    spdlog::error("{}", error_text(e));
    return 1;
  }
  return 0;
}

}  // namespace handscs
