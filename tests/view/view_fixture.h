// Test fixture: a tiny avatar trained for a few steps on the `tiny` synthetic capture (once per test
// process), and handscs-view's server on it, listening on a free loopback port in a thread.
#pragma once

#include <chrono>
#include <string>
#include <thread>

#include "core/threads.h"
#include "test_support.h"
#include "train/tiny_capture.h"
#include "train/trainer.h"
#include "view/view_server.h"

namespace handscs_test {

// A run folder with one checkpoint (5 steps: the avatar is near its start, which is all a
// viewer test needs: the picture must follow the pose and camera, not be good).
inline const std::string& tiny_trained_run() {
  static const std::string run = [] {
    handscs::set_threads(2);
    const std::string dir = fresh_dir("view_run");
    handscs::Trainer trainer(tiny_run_config(), dir);
    for (int i = 0; i < 5; ++i) trainer.step();
    trainer.save_checkpoint();
    return dir;
  }();
  return run;
}

inline handscs::ViewScene& tiny_view_scene() {
  static handscs::ViewScene scene = handscs::ViewScene::open(tiny_trained_run());
  return scene;
}

// The server on tiny_view_scene(), port 0 (any free one); stopped and joined on destruction.
struct RunningServer {
  explicit RunningServer(handscs::ViewServerConfig config = {}) : server(tiny_view_scene(), with_port0(config)) {
    port = server.bind();
    thread = std::thread([this] { server.run(); });
    while (!server.running()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ~RunningServer() {
    server.stop();
    thread.join();
  }
  static handscs::ViewServerConfig with_port0(handscs::ViewServerConfig config) {
    config.port = 0;
    if (config.save_poses == handscs::ViewServerConfig{}.save_poses)
      config.save_poses = scratch_path("view_server", "saved_poses.json");
    return config;
  }
  handscs::ViewServer server;
  int port = 0;
  std::thread thread;
};

}  // namespace handscs_test
