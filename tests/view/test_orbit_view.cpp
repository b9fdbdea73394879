// The viewer's orbit camera (view/orbit_view.h): it looks at the hand's centre from the requested
// distance, the hand's up is the image's up, and its camera passes the checks every camera file gets.
#include "catch_torch.h"

#include <cmath>

#include "core/camera_checks.h"
#include "test_support.h"
#include "view/orbit_view.h"

TEST_CASE("orbit view: centre in the middle of the image, distance kept, fingers up") {
  handscs::HandFrame hand;
  hand.centre = {0.1, -0.2, 0.5};
  hand.up = {0, 0, 2};         // not unit: normalised
  hand.front = {1, 0, 0.3};    // not orthogonal to up: made so
  for (double yaw : {0.0, 1.0, -2.5})
    for (double pitch : {-1.2, 0.0, 0.7}) {
      handscs::OrbitView view;
      view.yaw = yaw;
      view.pitch = pitch;
      view.distance = 0.4;
      view.width = 300;
      view.height = 200;
      const handscs::Camera c = handscs::orbit_view_camera(hand, view);
      INFO("yaw " << yaw << " pitch " << pitch);
      CHECK(handscs::rotation_problem(c.R).empty());
      CHECK(handscs::camera_intrinsics_problem(c).empty());
      const auto centre = c.to_camera(hand.centre);
      CHECK(std::abs(centre[2] - 0.4) < 1e-12);
      const auto uv = c.project_camera(centre);
      CHECK(std::abs(uv[0] - 150) < 1e-9);
      CHECK(std::abs(uv[1] - 100) < 1e-9);
      // A point above the centre (along up) lands higher in the image (smaller v), not sideways.
      const auto above = c.project_camera(c.to_camera({0.1, -0.2, 0.51}));
      CHECK(above[1] < 100);
      CHECK(std::abs(above[0] - 150) < 1e-9);
    }
}

TEST_CASE("orbit view: JSON bounds name the key; defaults fill what is missing") {
  using handscs::json;
  using handscs_test::error_of;
  handscs::OrbitView defaults;
  defaults.distance = 0.7;
  const auto view = handscs::orbit_view_from_json(json{{"yaw", 0.25}}, "v", defaults);
  CHECK(view.yaw == 0.25);
  CHECK(view.distance == 0.7);
  CHECK(view.width == 512);
  CHECK(error_of([&] { handscs::orbit_view_from_json(json{{"width", 100000}}, "v", defaults); }) ==
        "v.width: 100000 px is outside 32..2048");
  CHECK(error_of([&] { handscs::orbit_view_from_json(json{{"height", 100.5}}, "v", defaults); }) ==
        "v.height: expected an integer, got number");
  CHECK(error_of([&] { handscs::orbit_view_from_json(json{{"pitch", 1.6}}, "v", defaults); }) ==
        "v.pitch: 1.6 is outside -1.5..1.5");
  CHECK(error_of([&] { handscs::orbit_view_from_json(json{{"distance", 0}}, "v", defaults); }) ==
        "v.distance: 0.0 is outside 0.05..5.0");
  CHECK(error_of([&] { handscs::orbit_view_from_json(json{{"fov", 1}}, "v", defaults); }) ==
        "v.fov: unknown key (yaw, pitch, distance, width, height)");
}
