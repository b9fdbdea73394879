// handscs-bench-view: a load test of handscs-view's render endpoint on loopback. Serves a trained
// run in this process (the server of handscs-view, its own threads) and sends render requests from
// 1 and 4 client threads, each keeping one request in flight as the page does, for at most
// --seconds and --max-frames per setting (after --warmup frames). Two kinds of request: "pose"
// (every frame a new slider pose: the full forward) and "orbit" (one pose, a new camera yaw each
// frame: rasterisation and encoding only, as when dragging). Prints one JSON object:
// frames per second and latency percentiles (ms) per client count and kind, the server's frame
// time, the Gaussian count and the load average while it ran.
//   handscs-bench-view --checkpoint RUN [--clients 1,4] [--seconds 10] [--max-frames 300]
//                      [--width 512] [--height 334] [--threads 1]
#include <algorithm>
#include <atomic>
#include <cstdio>
#include <sstream>
#include <thread>

#include <CLI/CLI.hpp>
#include <httplib.h>
#include <nlohmann/json.hpp>

#include "core/logging.h"
#include "core/threads.h"
#include "view/view_server.h"
#include "bench_timing.h"

namespace {

using bench::Clock;
using bench::ms_since;
using bench::seconds_since;

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  return values[std::min(values.size() - 1, static_cast<size_t>(p / 100 * values.size()))];
}

std::string request_body(const std::string& kind, int client, int64_t k, int width, int height) {
  // Poses walk the index and middle flexion through their range; orbit frames turn the camera.
  const double t = static_cast<double>((k * 7 + client * 3) % 50) / 50.0;
  std::ostringstream body;
  body << "{\"controls\": {\"index.mcp\": " << (kind == "pose" ? t : 0.3) << ", \"middle.pip\": "
       << (kind == "pose" ? 1 - t : 0.5) << "}, \"view\": {\"yaw\": " << (kind == "orbit" ? 6.28 * t : 0.4)
       << ", \"width\": " << width << ", \"height\": " << height << "}}";
  return body.str();
}

nlohmann::json run_setting(int port, const std::string& kind, int clients, double seconds, int64_t max_frames,
                           int64_t warmup, int width, int height) {
  std::vector<std::vector<double>> latency(clients), server_ms(clients);
  std::atomic<int64_t> sent{0}, failed{0};
  // Warm-up: the first frames of a setting (memory, the frozen decoders) are not timed.
  {
    httplib::Client client("127.0.0.1", port);
    for (int64_t k = 0; k < warmup; ++k) client.Post("/api/render", request_body(kind, 0, k, width, height), "application/json");
  }
  const auto start = Clock::now();
  std::vector<std::thread> threads;
  for (int c = 0; c < clients; ++c)
    threads.emplace_back([&, c] {
      httplib::Client client("127.0.0.1", port);
      for (int64_t k = 0;; ++k) {
        if (seconds_since(start) >= seconds || sent.fetch_add(1) >= max_frames) break;
        const auto t0 = Clock::now();
        const auto reply = client.Post("/api/render", request_body(kind, c, k, width, height), "application/json");
        if (!reply || reply->status != 200) {
          ++failed;
          continue;
        }
        latency[c].push_back(ms_since(t0));
        server_ms[c].push_back(std::stod(reply->get_header_value("X-Frame-Ms")));
      }
    });
  for (auto& t : threads) t.join();
  const double elapsed = seconds_since(start);
  std::vector<double> all, frame;
  for (int c = 0; c < clients; ++c) {
    all.insert(all.end(), latency[c].begin(), latency[c].end());
    frame.insert(frame.end(), server_ms[c].begin(), server_ms[c].end());
  }
  return {{"kind", kind},
          {"clients", clients},
          {"frames", all.size()},
          {"failed", failed.load()},
          {"seconds", elapsed},
          {"fps", all.size() / elapsed},
          {"latency_ms", {{"p50", percentile(all, 50)}, {"p90", percentile(all, 90)}, {"p99", percentile(all, 99)},
                          {"max", percentile(all, 100)}}},
          {"server_frame_ms", {{"p50", percentile(frame, 50)}, {"p90", percentile(frame, 90)}}}};
}

}  // namespace

int main(int argc, char** argv) {
  handscs::log_to_stderr();  // stdout carries the JSON only
  CLI::App app{"handscs-view load test on loopback (prints JSON)"};
  std::string checkpoint, clients_list = "1,4";
  double seconds = 10;
  int64_t max_frames = 300, warmup = 5;
  int width = 512, height = 334, threads = 1;
  app.add_option("--checkpoint", checkpoint, "checkpoint file or run folder")->required();
  app.add_option("--clients", clients_list, "comma-separated client counts");
  app.add_option("--seconds", seconds, "longest time per setting")->check(CLI::Range(0.1, 600.0));
  app.add_option("--max-frames", max_frames, "most frames per setting")->check(CLI::Range(1, 100000));
  app.add_option("--warmup", warmup, "untimed frames before each setting")->check(CLI::Range(0, 1000));
  app.add_option("--width", width);
  app.add_option("--height", height);
  app.add_option("--threads", threads, "LibTorch/OpenMP threads of the renderer");
  CLI11_PARSE(app, argc, argv);
  try {
    handscs::set_threads(threads);
    handscs::ViewScene scene = handscs::ViewScene::open(checkpoint);
    handscs::ViewServerConfig config;
    config.port = 0;
    config.save_poses = "/dev/null";  // nothing is saved
    handscs::ViewServer server(scene, config);
    const int port = server.bind();
    std::thread serving([&] { server.run(); });
    while (!server.running()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    nlohmann::json result;
    result["gaussians"] = scene.info()["gaussians"];
    result["width"] = width;
    result["height"] = height;
    result["threads"] = threads;
    result["load_average_before"] = bench::load_average();
    result["settings"] = nlohmann::json::array();
    std::stringstream list(clients_list);
    for (std::string item; std::getline(list, item, ',');)
      for (const std::string kind : {"pose", "orbit"})
        result["settings"].push_back(run_setting(port, kind, std::stoi(item), seconds, max_frames, warmup, width, height));
    result["load_average_after"] = bench::load_average();
    server.stop();
    serving.join();
    std::printf("%s\n", result.dump(1).c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "handscs-bench-view: %s\n", e.what());
    return 1;
  }
  return 0;
}
