// handscs-rig: writes the built-in procedural hand as a rig file, prints a rig's summary, exports
// its template mesh as OBJ (docs/RIG_FORMAT.md).
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>

#include "core/cli.h"
#include "hand/rig_tool.h"

int main(int argc, char** argv) {
  CLI::App app{"handscs-rig: built-in hand rig files and rig summaries"};
  handscs::CommonOptions common;
  handscs::RigToolOptions options;
  handscs::add_common_options(app, common, false);
  app.add_flag("--builtin", options.builtin, "use the built-in procedural hand");
  app.add_flag("--left", options.left, "with --builtin: the left hand (mirror of the right)");
  app.add_option("--out", options.out, "with --builtin: rig file to write (JSON)");
  app.add_option("--info", options.info,
                 "print a summary of RIG: a rig file, 'builtin' or 'builtin:left'");
  app.add_option("--obj", options.obj, "write the rig's template mesh as a Wavefront OBJ file");
  CLI11_PARSE(app, argc, argv);
  try {
    handscs::start_up(common, "handscs-rig");
    handscs::run_rig_tool(options);
  } catch (const std::exception& e) {
    spdlog::error("{}", handscs::error_text(e));
    return 1;
  }
  return 0;
}
