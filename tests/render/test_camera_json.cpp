// Camera files for the renderer: round trip and exact error messages.
#include "catch_torch.h"  // first: torch, minus glog's CHECK, then Catch2

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>

#include "core/atomic_file.h"
#include "render/camera_json.h"
#include "test_support.h"

using namespace handscs;
namespace fs = std::filesystem;

namespace {

using handscs_test::error_of;

Camera parse(const std::string& text) { return camera_from_json(json::parse(text), "cam.json"); }

const char* kGood =
    R"({"K": [[500, 0, 256.5], [0, 510, 167], [0, 0, 1]], "R": [[0, -1, 0], [1, 0, 0], [0, 0, 1]],
        "t": [0.1, -0.2, 0.9], "width": 512, "height": 334})";

}  // namespace

TEST_CASE("camera JSON: reads K, R, t, size (and optional near/far), writes them back") {
  const Camera c = parse(kGood);
  CHECK(c.fx() == 500);
  CHECK(c.fy() == 510);
  CHECK(c.cx() == 256.5);
  CHECK(c.R[1] == -1);
  CHECK(c.t[2] == 0.9);
  CHECK(c.width == 512);
  CHECK(c.height == 334);
  CHECK(c.near_plane == 0.01);
  const fs::path path = fs::temp_directory_path() / ("handscs_cam_" + std::to_string(::getpid()) + ".json");
  Camera d = c;
  d.near_plane = 0.05;
  write_camera_json(path.string(), d);
  const Camera e = read_camera_json(path.string());
  fs::remove(path);
  CHECK(e.K == d.K);
  CHECK(e.R == d.R);
  CHECK(e.t == d.t);
  CHECK(e.near_plane == 0.05);
  CHECK(e.far_plane == d.far_plane);
}

TEST_CASE("camera JSON: bad files name the file and the key") {
  auto err = [](const std::string& text) { return error_of([&] { parse(text); }); };
  std::string good = kGood;
  auto with = [&](const std::string& from, const std::string& to) {
    std::string s = good;
    s.replace(s.find(from), from.size(), to);
    return s;
  };
  CHECK(err(with("\"width\": 512", "\"width\": 512, \"focal\": 3")) ==
        "cam.json: focal: unknown key (known: K, R, t, width, height, near, far)");
  CHECK(err(with(", \"height\": 334", "")) == "cam.json: height: missing");
  CHECK(err(with("[0, 510, 167]", "[0, 510]")) == "cam.json: K[1]: expected a row of 3 numbers");
  CHECK(err(with("256.5", "\"c\"")) == "cam.json: K[0][2]: expected number, got string");
  CHECK(err(with("[0, 0, 1]], \"R\"", "[0, 0, 2]], \"R\"")) ==
        "cam.json: K: expected [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (no skew)");
  CHECK(err(with("[0, -1, 0]", "[0, -2, 0]")) == "cam.json: R: not a rotation matrix (R R^T != I or det < 0)");
  CHECK(err(with("[0.1, -0.2, 0.9]", "[0.1, -0.2]")) == "cam.json: t: expected an array of 3 numbers");
  CHECK(err(with("\"width\": 512", "\"width\": 0")) == "cam.json: width: expected a positive integer, got 0");
  CHECK(err(with("\"width\": 512", "\"width\": 512, \"near\": 2, \"far\": 1")) ==
        "cam.json: near: need 0 < near < far, got 2.000000, 1.000000");
  CHECK(error_of([] { read_camera_json("/nonexistent/cam.json"); }) == "/nonexistent/cam.json: cannot open file");
  // Implausible intrinsics and sizes (core/camera_checks.h), named.
  CHECK(err(with("256.5", "1e12")) == "cam.json: K: cx = 1e+12 lies more than 1 image width outside the image (0-512)");
  CHECK(err(with("[[500,", "[[1e-30,")) ==
        "cam.json: K: fx = 1e-30 is 1.95313e-33 image widths: outside the plausible 0.04-120 (fields of view of 170 "
        "to 0.5 degrees)");
  CHECK(err(with("\"width\": 512, \"height\": 334", "\"width\": 30000, \"height\": 30000")) ==
        "cam.json: width: image of 30000x30000 = 900 megapixels exceeds the 100 megapixel limit");
}
