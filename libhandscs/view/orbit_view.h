// The viewer's orbit camera: yaw and pitch around the hand and a distance, in the hand's own frame
// (its root joint's transform applied to the rest hand's centre, long axis and palm normal), so the
// view follows the hand from pose to pose; fingers point up in the image.
//   position = centre + distance (cos(pitch) (cos(yaw) front + sin(yaw) side) + sin(pitch) up)
#pragma once

#include <array>
#include <string>

#include "core/camera.h"
#include "core/config.h"

namespace handscs {

// Image sides the viewer renders: 32 px shows a hand at all; 2048 px is wider than a browser panel
// needs, and keeps a frame's raster state (~20 bytes a pixel) under ~85 MB.
constexpr int kMinViewSide = 32;
constexpr int kMaxViewSide = 2048;
// |pitch| below 90 degrees: at the pole the image's up direction is undefined.
constexpr double kMaxViewPitch = 1.5;
// Camera distances (m): from 5 cm (a fingertip fills the view) to 5 m (a hand is a few pixels).
constexpr double kMinViewDistance = 0.05, kMaxViewDistance = 5.0;

struct OrbitView {
  double yaw = 0;        // rad around the hand's long axis; 0 looks at the palm side's opposite
  double pitch = 0.3;    // rad above the palm plane
  double distance = 0.5; // m from the hand's centre
  int width = 512;       // px (InterHand2.6M's image size)
  int height = 334;
};

// Reads {"yaw", "pitch", "distance", "width", "height"} over `defaults`; values outside the
// bounds above are errors starting with `where`.
OrbitView orbit_view_from_json(const json& object, const std::string& where, const OrbitView& defaults);
json orbit_view_to_json(const OrbitView& view);

// The hand's frame in world coordinates: centre looked at, long axis (wrist -> fingers) and the
// direction yaw 0 looks from; up and front need not be exactly orthogonal (front is made so).
struct HandFrame {
  std::array<double, 3> centre{}, up{0, 1, 0}, front{0, 0, 1};
};

// Focal length (px) of a view: a 30-degree vertical field of view, a lens of hand captures.
double view_focal(int width, int height);
// The distance at which a hand of `extent` metres fills ~70% of the image's shorter side.
double fitting_distance(double extent, int width, int height);

Camera orbit_view_camera(const HandFrame& hand, const OrbitView& view);

}  // namespace handscs
