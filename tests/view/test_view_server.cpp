// handscs-view's server end to end on loopback: the page and its data, frames equal to handscs-render's
// for the same pose and camera (render_avatar, the avatar mode's code, on the files the server's
// camera and save endpoints give), and saved poses read back by the POSES reader exactly.
#include "catch_torch.h"

#include <filesystem>

#include <httplib.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/atomic_file.h"
#include "infer/avatar_render.h"
#include "raw_http.h"
#include "render/camera_json.h"
#include "view_fixture.h"

namespace {

using handscs::json;

// Renders through handscs-render's avatar mode (the first pose of `poses`, from `camera`).
cv::Mat render_avatar_frame(const std::string& poses, const std::string& camera, const std::string& out_dir) {
  handscs::AvatarRenderOptions options;
  options.checkpoint = handscs_test::tiny_trained_run();
  options.poses = poses;
  options.camera = camera;
  options.out_dir = out_dir;
  handscs::render_avatar(options);
  return cv::imread(out_dir + "/frame_0000.png", cv::IMREAD_COLOR);
}

cv::Mat decode(const std::string& bytes) {
  return cv::imdecode(cv::Mat(1, static_cast<int>(bytes.size()), CV_8UC1, const_cast<char*>(bytes.data())),
                      cv::IMREAD_COLOR);
}

}  // namespace

TEST_CASE("view server: the page and its start-up data") {
  handscs_test::RunningServer s;
  httplib::Client client("127.0.0.1", s.port);
  const auto page = client.Get("/");
  REQUIRE(page);
  CHECK(page->status == 200);
  CHECK(page->get_header_value("Content-Type") == "text/html; charset=utf-8");
  CHECK(page->body.find("<title>handscs-view</title>") != std::string::npos);
  const auto info_reply = client.Get("/api/info");
  REQUIRE(info_reply);
  REQUIRE(info_reply->status == 200);
  const json info = json::parse(info_reply->body);
  CHECK(info["gaussians"].get<int64_t>() > 1000);  // the built-in hand's Gaussians (1,696 at the start)
  CHECK(info["held_out"].size() == 3);             // tiny_run_config holds out 3 poses
  CHECK(info["controls"].size() == 15);
  CHECK(info["gestures"].size() == handscs::gesture_vocabulary().size() + 1);
  CHECK(info["view"]["width"] == 512);
}

TEST_CASE("view server: a port in use is an error naming host and port") {
  handscs_test::RunningServer s;
  handscs::ViewServerConfig config;
  config.port = s.port;
  handscs::ViewServer second(handscs_test::tiny_view_scene(), config);
  CHECK(handscs_test::error_of([&] { second.bind(); }) ==
        "--host 127.0.0.1 --port " + std::to_string(s.port) +
            ": cannot listen there (the port is in use, or the host is not an address of this machine)");
}

TEST_CASE("view server: a Host that only starts like loopback and a type like JSON are refused") {
  handscs_test::RunningServer s;
  const auto info = [&](const std::string& host) {
    return handscs_test::raw_status(s.port, "GET /api/info HTTP/1.1\r\nHost: " + host +
                                                "\r\nConnection: close\r\n\r\n");
  };
  CHECK(info("127.0.0.1:" + std::to_string(s.port)) == 200);
  CHECK(info("127.evil.com") == 403);  // DNS rebinding: a name its owner points at 127.0.0.1
  CHECK(info("127.0.0.1.nip.io:" + std::to_string(s.port)) == 403);
  const std::string body = R"({"held_out": 0})";
  const auto camera = [&](const std::string& type) {
    return handscs_test::raw_status(s.port, "POST /api/camera HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: " +
                                                type + "\r\nContent-Length: " + std::to_string(body.size()) +
                                                "\r\nConnection: close\r\n\r\n" + body);
  };
  CHECK(camera("application/json; charset=utf-8") == 200);
  CHECK(camera("application/jsonp-evil") == 415);
}

TEST_CASE("view server: frames equal handscs-render's for the same pose and camera") {
  handscs_test::RunningServer s;
  httplib::Client client("127.0.0.1", s.port);
  const std::string dir = handscs_test::fresh_dir("view_frames");
  std::filesystem::create_directories(dir);
  struct Case {
    std::string name, state;
  };
  // A slider pose from an oblique view, and a held-out pose of the capture from below.
  const std::vector<Case> cases = {
      {"controls", R"("controls": {"index.mcp": 0.6, "middle.pip": 0.8, "thumb.opposition": 0.5, "spread": -0.4},
                      "view": {"yaw": 0.7, "pitch": 0.2, "width": 200, "height": 160})"},
      {"held_out", R"("held_out": 2, "view": {"yaw": -2.0, "pitch": -0.6, "distance": 0.4, "width": 240, "height": 180})"}};
  std::vector<cv::Mat> frames;
  for (const auto& c : cases) {
    INFO(c.name);
    const std::string png_body = "{" + c.state + R"(, "format": "png"})";
    const auto png = client.Post("/api/render", png_body, "application/json");
    REQUIRE(png);
    REQUIRE(png->status == 200);
    CHECK(png->get_header_value("Content-Type") == "image/png");
    CHECK(std::stod(png->get_header_value("X-Frame-Ms")) > 0);
    const cv::Mat frame = decode(png->body);
    REQUIRE_FALSE(frame.empty());

    // The same state's camera and pose as files, rendered by handscs-render's avatar mode.
    const auto camera = client.Post("/api/camera", png_body, "application/json");
    REQUIRE(camera);
    REQUIRE(camera->status == 200);
    const std::string camera_file = dir + "/" + c.name + "_camera.json";
    handscs::write_camera_json(camera_file, handscs::camera_from_json(json::parse(camera->body), "reply"));
    const std::string poses_file = dir + "/" + c.name + "_poses.json";
    handscs_test::RunningServer saver(handscs::ViewServerConfig{"127.0.0.1", 0, poses_file});
    httplib::Client save_client("127.0.0.1", saver.port);
    const auto saved = save_client.Post("/api/save", png_body, "application/json");
    REQUIRE(saved);
    REQUIRE(saved->status == 200);
    CHECK(json::parse(saved->body)["count"] == 1);
    const cv::Mat reference = render_avatar_frame(poses_file, camera_file, dir + "/" + c.name + "_render");
    REQUIRE(reference.size() == frame.size());
    CHECK(cv::norm(frame, reference, cv::NORM_INF) == 0);  // PNG: the same pixels
    CHECK(cv::countNonZero(reference.reshape(1)) > frame.total() / 20);  // a hand in view, not black

    // JPEG at the page's quality 90: close to the exact frame (measured 40.1 and 43.8 dB on these two
    // small, edge-dense views); 35 dB is an RMS error of ~4.5 levels of 255, far above what another
    // pose or view scores (below 25 dB, checked at the end).
    const auto jpeg = client.Post("/api/render", "{" + c.state + "}", "application/json");
    REQUIRE(jpeg);
    CHECK(jpeg->get_header_value("Content-Type") == "image/jpeg");
    const double psnr = cv::PSNR(decode(jpeg->body), reference);
    INFO("JPEG PSNR " << psnr << " dB");
    CHECK(psnr > 35);
    frames.push_back(frame);
  }
  // Another pose and view is another picture.
  cv::Mat a, b;
  cv::resize(frames[0], a, cv::Size(100, 80));
  cv::resize(frames[1], b, cv::Size(100, 80));
  CHECK(cv::PSNR(a, b) < 25);
}

TEST_CASE("view server: saved poses are a POSES list, read back exactly, appended in order") {
  const std::string file = handscs_test::scratch_path("view_save", "poses.json");
  std::filesystem::remove(file);
  handscs_test::RunningServer s(handscs::ViewServerConfig{"127.0.0.1", 0, file});
  httplib::Client client("127.0.0.1", s.port);
  const std::vector<std::string> bodies = {R"({"held_out": 1})", R"({"controls": {"ring.dip": 0.3}})",
                                           R"({"held_out": 0})"};
  for (size_t i = 0; i < bodies.size(); ++i) {
    const auto reply = client.Post("/api/save", bodies[i], "application/json");
    REQUIRE(reply);
    REQUIRE(reply->status == 200);
    CHECK(json::parse(reply->body)["count"] == i + 1);
  }
  const auto frames = handscs::read_pose_source(file);
  REQUIRE(frames.size() == 3);
  auto& scene = handscs_test::tiny_view_scene();
  for (size_t i = 0; i < bodies.size(); ++i) {
    const auto expected = scene.pose_of(handscs::parse_view_request(bodies[i], scene.default_view()));
    CHECK(frames[i].pose == expected.pose);
    CHECK(frames[i].shape == expected.shape);
    CHECK(frames[i].trans == expected.trans);
  }
  // Held-out poses keep their names, slider poses are numbered.
  CHECK(frames[0].name == scene.info()["held_out"][1].get<std::string>());
  CHECK(frames[1].name == "view_0001");
  // A file that is not a POSES list is refused and left as it was.
  const std::string other = handscs_test::scratch_file("view_save", "other.json", "{\"train\": {}}");
  handscs_test::RunningServer refusing(handscs::ViewServerConfig{"127.0.0.1", 0, other});
  httplib::Client refused_client("127.0.0.1", refusing.port);
  const auto refused = refused_client.Post("/api/save", "{}", "application/json");
  REQUIRE(refused);
  CHECK(refused->status == 400);
  CHECK(json::parse(refused->body)["error"].get<std::string>().find("not a POSES list") != std::string::npos);
  CHECK(handscs::read_file(other) == "{\"train\": {}}");
}

TEST_CASE("view server: a POSES file without the one-hand avatar's hand is refused at start") {
  // Its left hand alone was drawn with the left hand's parameters on the right-hand avatar.
  const nlohmann::json left = {{"pose", std::vector<double>(48, -0.3)}, {"trans", {0.1, 0.0, 1.0}}};
  const std::string path = handscs_test::scratch_path("view_two_hand_poses", "left.json");
  handscs::write_file_atomic(path, nlohmann::json{{"poses", {{{"left", left}}}}}.dump());
  CHECK(handscs_test::error_of([&] { handscs::ViewScene::open(handscs_test::tiny_trained_run(), path); }) ==
        path + ": pose 0 has no right hand, and the avatar is the right hand's alone (data.hand right)");
}
