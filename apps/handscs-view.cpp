// handscs-view: a trained avatar in the browser. Serves one page (sliders per joint group, gestures,
// the run capture's held-out poses, an orbit camera, "save pose") and its render endpoint:
//   --checkpoint RUN [--port 8080] [--host 127.0.0.1] [--save-poses FILE] [--workers N]
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "core/cli.h"
#include "view/view_command.h"

int main(int argc, char** argv) {
  CLI::App app{"handscs-view: a trained avatar in the browser"};
  handscs::CommonOptions common;
  handscs::add_common_options(app, common, false);
  handscs::ViewCommandLine view;
  handscs::add_view_options(app, view);
  CLI11_PARSE(app, argc, argv);
  try {
    handscs::start_up(common, "handscs-view");
    handscs::run_view_command(view);
  } catch (const std::exception& e) {
    spdlog::error("{}", handscs::error_text(e));
    return 1;
  }
  return 0;
}
