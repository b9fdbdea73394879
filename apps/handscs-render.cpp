// handscs-render: placeholder main until its issue lands; parses the shared options.
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "core/cli.h"

int main(int argc, char** argv) {
  CLI::App app{"handscs-render"};
  handscs::CommonOptions common;
  handscs::add_common_options(app, common, true);
  CLI11_PARSE(app, argc, argv);
  try {
    handscs::start_up(common, "handscs-render");
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
