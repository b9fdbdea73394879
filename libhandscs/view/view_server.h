// handscs-view's HTTP server (cpp-httplib): one page and four endpoints, nothing else (no files,
// no folder listings, no paths from the client):
//   GET  /             the page (view/view_page.h)
//   GET  /api/info     the scene's start-up data (ViewScene::info)
//   POST /api/render   a view request (view/view_request.h) -> the frame as image/jpeg or image/png,
//                      with headers X-Frame-Ms (the server's frame time) and X-Gaussians
//   POST /api/camera   a view request -> its camera as a camera JSON (render/camera_json.h)
//   POST /api/save     a view request -> its pose appended to the --save-poses file (view/pose_saver.h)
// Bad requests get 4xx with {"error": "..."} naming the key at fault; POST bodies must be
// application/json (so another site's page cannot post to the server without a CORS preflight,
// which is never granted) and at most kMaxViewRequestBytes; on a loopback address, requests whose
// Host header is not a loopback name are refused (DNS rebinding; view/request_headers.h).
#pragma once

#include <memory>
#include <mutex>
#include <string>

#include "view/view_scene.h"

namespace httplib {
class Server;
}

namespace handscs {

struct ViewServerConfig {
  std::string host = "127.0.0.1";  // loopback only unless the user says otherwise
  int port = 8080;                 // 0: any free port (tests)
  std::string save_poses = "handscs-view-poses.json";  // where "save pose" appends
  // Connection threads. Each open connection holds one until it idles out (read_timeout_s), so
  // this many slow or idle clients can make others wait that long; frames render one at a time.
  int workers = 32;
  int read_timeout_s = 5;    // a request must arrive within this (slow-loris clients are dropped)
  int keep_alive_s = 5;      // idle keep-alive connections close after this
};

class ViewServer {
 public:
  ViewServer(ViewScene& scene, ViewServerConfig config);
  ~ViewServer();

  // Binds config.host:config.port and returns the port bound. Throws Error when it cannot.
  int bind();
  // Serves until stop() (from another thread). bind() first.
  void run();
  bool running() const;  // run() is serving (stop() before that would not reach it)
  void stop();

 private:
  void add_routes();

  ViewScene& scene_;
  ViewServerConfig config_;
  std::unique_ptr<httplib::Server> http_;
  std::mutex save_mutex_;
};

}  // namespace handscs
