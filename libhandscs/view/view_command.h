// handscs-view on the command line: --checkpoint RUN [--poses FILE] [--port P] [--host H]
// [--save-poses FILE] [--workers N]; opens the scene, binds, logs the address and serves until killed.
#pragma once

#include <string>

#include "view/view_server.h"

namespace CLI {
class App;
}

namespace handscs {

struct ViewCommandLine {
  std::string checkpoint;  // checkpoint file or run folder
  std::string poses;       // POSES or keypoint file to step through ("" = the run's held-out poses)
  ViewServerConfig server;
};

void add_view_options(CLI::App& app, ViewCommandLine& cli);

// Serves until the process is stopped. Throws Error for a bad checkpoint or an address it cannot bind.
void run_view_command(const ViewCommandLine& cli);

}  // namespace handscs
