#include "view/view_command.h"

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "view/request_headers.h"

namespace handscs {

void add_view_options(CLI::App& app, ViewCommandLine& cli) {
  app.add_option("--checkpoint", cli.checkpoint, "checkpoint file or run folder (its latest checkpoint)")
      ->required();
  app.add_option("--poses", cli.poses,
                 "POSES file, or keypoint file fitted with the avatar's rig (docs/FIT.md), whose poses the page "
                 "steps through instead of the run's held-out poses");
  app.add_option("--port", cli.server.port, "TCP port (0: any free port)")
      ->check(CLI::Range(0, 65535))
      ->capture_default_str();
  app.add_option("--host", cli.server.host,
                 "address to listen on; anything but loopback exposes the viewer to the network")
      ->capture_default_str();
  app.add_option("--save-poses", cli.server.save_poses,
                 "POSES file the page's \"save pose\" button appends to (handscs-render --poses reads it)")
      ->capture_default_str();
  app.add_option("--workers", cli.server.workers, "connection threads (idle connections each hold one)")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
}

void run_view_command(const ViewCommandLine& cli) {
  ViewScene scene = ViewScene::open(cli.checkpoint, cli.poses);
  ViewServer server(scene, cli.server);
  const int port = server.bind();
  if (!is_loopback_host(cli.server.host))
    spdlog::warn("--host {}: the viewer is reachable from other machines; it has no authentication, and "
                 "anyone who reaches it can render and append poses to {}",
                 cli.server.host, cli.server.save_poses);
  const json info = scene.info();
  spdlog::info("{} Gaussians, {} held-out poses; serving http://{}:{}/", info["gaussians"].get<int64_t>(),
               info["held_out"].size(),
               cli.server.host.find(':') != std::string::npos ? "[" + cli.server.host + "]" : cli.server.host,
               port);
  server.run();
}

}  // namespace handscs
