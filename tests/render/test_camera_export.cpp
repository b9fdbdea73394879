// render/camera_export.h: a camera written to nerfstudio's transforms.json projects every point to
// the same pixel when the frame is read the way nerfstudio documents it (camera-to-world in OpenGL
// axes: x right, y up, looking down -z; pixel centres at i + 0.5), and reads back to itself.
#include "catch_torch.h"

#include <random>

#include "render/camera_export.h"

using namespace handscs;

namespace {

// A camera looking at the origin from a random direction, with a random roll and intrinsics.
Camera random_camera(std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::array<double, 3> z{unit(rng), unit(rng), unit(rng)};
  const double zn = std::sqrt(z[0] * z[0] + z[1] * z[1] + z[2] * z[2]);
  for (double& v : z) v /= zn;
  std::array<double, 3> up{unit(rng), unit(rng), unit(rng)};
  // x = up x z normalised, y = z x x: a right-handed orthonormal frame (rows of R).
  std::array<double, 3> x{up[1] * z[2] - up[2] * z[1], up[2] * z[0] - up[0] * z[2],
                          up[0] * z[1] - up[1] * z[0]};
  const double xn = std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
  for (double& v : x) v /= xn;
  const std::array<double, 3> y{z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2],
                                z[0] * x[1] - z[1] * x[0]};
  Camera c;
  c.R = {x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]};
  const std::array<double, 3> centre{-z[0] * 1.2, -z[1] * 1.2, -z[2] * 1.2};  // 1.2 m away
  for (int r = 0; r < 3; ++r)
    c.t[r] = -(c.R[r * 3] * centre[0] + c.R[r * 3 + 1] * centre[1] + c.R[r * 3 + 2] * centre[2]);
  c.width = 334;
  c.height = 512;
  c.K = {1200 + 100 * unit(rng), 0, 167 + 10 * unit(rng), 0, 1210 + 100 * unit(rng),
         256 + 10 * unit(rng), 0, 0, 1};
  return c;
}

// nerfstudio's reading of a frame: world point -> OpenGL camera coordinates through the inverse
// of transform_matrix, then u = fl_x x / -z + cx, v = fl_y (-y) / -z + cy.
std::array<double, 2> nerfstudio_project(const json& frame, const std::array<double, 3>& p) {
  const json& m = frame["transform_matrix"];
  std::array<double, 3> d{};
  for (int r = 0; r < 3; ++r) d[r] = p[r] - m[r][3].get<double>();
  std::array<double, 3> gl{};  // R_c2w^T (p - centre)
  for (int k = 0; k < 3; ++k)
    for (int r = 0; r < 3; ++r) gl[k] += m[r][k].get<double>() * d[r];
  const double depth = -gl[2];
  return {frame["fl_x"].get<double>() * gl[0] / depth + frame["cx"].get<double>(),
          frame["fl_y"].get<double>() * -gl[1] / depth + frame["cy"].get<double>()};
}

}  // namespace

TEST_CASE("camera export: transforms.json frames project like our cameras and read back") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> near_origin(-0.1, 0.1);
  std::vector<CameraFrame> frames;
  for (int k = 0; k < 20; ++k) frames.push_back({"frame_" + std::to_string(k) + ".png", random_camera(rng)});
  const json transforms = nerfstudio_transforms(frames);
  CHECK(transforms["camera_model"] == "OPENCV");
  REQUIRE(transforms["frames"].size() == frames.size());
  double worst_pixel = 0, worst_matrix = 0;
  for (size_t k = 0; k < frames.size(); ++k) {
    const json& frame = transforms["frames"][k];
    const Camera& camera = frames[k].camera;
    CHECK(frame["file_path"] == frames[k].file_path);
    CHECK(frame["w"] == 334);
    CHECK(frame["h"] == 512);
    for (int i = 0; i < 10; ++i) {
      const std::array<double, 3> p{near_origin(rng), near_origin(rng), near_origin(rng)};
      const auto ours = camera.project_camera(camera.to_camera(p));
      const auto theirs = nerfstudio_project(frame, p);
      worst_pixel = std::max({worst_pixel, std::abs(ours[0] - theirs[0]), std::abs(ours[1] - theirs[1])});
    }
    const Camera back = camera_from_nerfstudio_frame(frame, "transforms.json");
    for (int i = 0; i < 9; ++i) {
      worst_matrix = std::max({worst_matrix, std::abs(back.R[i] - camera.R[i]), std::abs(back.K[i] - camera.K[i])});
    }
    for (int i = 0; i < 3; ++i) worst_matrix = std::max(worst_matrix, std::abs(back.t[i] - camera.t[i]));
    CHECK(back.width == camera.width);
    CHECK(back.height == camera.height);
  }
  CHECK(worst_pixel < 1e-9);
  CHECK(worst_matrix < 1e-12);
  CHECK_THROWS_WITH(camera_from_nerfstudio_frame(json{{"w", 3}}, "t.json"),
                    Catch::StartsWith("t.json: not a transforms.json frame"));
}
