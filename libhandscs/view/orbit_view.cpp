#include "view/orbit_view.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/vec3.h"

namespace handscs {

namespace {

// Vertical field of view of every view (rad): 30 degrees.
constexpr double kViewFieldOfView = 30.0 * M_PI / 180.0;
// Share of the image's shorter side a hand fills at the fitting distance.
constexpr double kViewFill = 0.7;

double number(const json& object, const char* key, double value, double lo, double hi,
              const std::string& where) {
  const auto it = object.find(key);
  if (it == object.end()) return value;
  const std::string path = where + "." + key;
  require(it->is_number(), path + ": expected a number, got " + json_type_name(*it));
  const double v = it->get<double>();
  require(std::isfinite(v) && v >= lo && v <= hi,
          path + ": " + json(v).dump() + " is outside " + json(lo).dump() + ".." + json(hi).dump());
  return v;
}

int side(const json& object, const char* key, int value, const std::string& where) {
  const auto it = object.find(key);
  if (it == object.end()) return value;
  const std::string path = where + "." + key;
  require(it->is_number_integer(), path + ": expected an integer, got " + json_type_name(*it));
  const int64_t v = it->get<int64_t>();
  require(v >= kMinViewSide && v <= kMaxViewSide, path + ": " + std::to_string(v) + " px is outside " +
                                                      std::to_string(kMinViewSide) + ".." +
                                                      std::to_string(kMaxViewSide));
  return static_cast<int>(v);
}

}  // namespace

OrbitView orbit_view_from_json(const json& object, const std::string& where, const OrbitView& defaults) {
  require(object.is_object(), where + ": expected an object, got " + json_type_name(object));
  for (auto it = object.begin(); it != object.end(); ++it)
    require(it.key() == "yaw" || it.key() == "pitch" || it.key() == "distance" || it.key() == "width" ||
                it.key() == "height",
            where + "." + it.key() + ": unknown key (yaw, pitch, distance, width, height)");
  OrbitView view;
  // Any yaw is a direction; the bound only keeps cos/sin exact enough to mean what was sent.
  view.yaw = number(object, "yaw", defaults.yaw, -1e3, 1e3, where);
  view.pitch = number(object, "pitch", defaults.pitch, -kMaxViewPitch, kMaxViewPitch, where);
  view.distance = number(object, "distance", defaults.distance, kMinViewDistance, kMaxViewDistance, where);
  view.width = side(object, "width", defaults.width, where);
  view.height = side(object, "height", defaults.height, where);
  return view;
}

json orbit_view_to_json(const OrbitView& view) {
  return {{"yaw", view.yaw}, {"pitch", view.pitch}, {"distance", view.distance},
          {"width", view.width}, {"height", view.height}};
}

double view_focal(int width, int height) { return 0.5 * height / std::tan(0.5 * kViewFieldOfView); }

double fitting_distance(double extent, int width, int height) {
  return std::clamp(view_focal(width, height) * extent / (kViewFill * std::min(width, height)),
                    kMinViewDistance, kMaxViewDistance);
}

Camera orbit_view_camera(const HandFrame& hand, const OrbitView& view) {
  const Vec3 up = normalized(hand.up);
  const Vec3 front = normalized(hand.front - up * dot(hand.front, up));
  const Vec3 side_axis = cross(up, front);
  const Vec3 around = front * std::cos(view.yaw) + side_axis * std::sin(view.yaw);
  const Vec3 dir = around * std::cos(view.pitch) + up * std::sin(view.pitch);
  const Vec3 position = hand.centre + dir * view.distance;
  const Vec3 z = dir * -1.0;                             // forward, towards the centre
  const Vec3 y = normalized(z * dot(up, z) - up);        // image down = -up, made orthogonal to z
  const Vec3 x = cross(y, z);
  Camera c;
  c.width = view.width;
  c.height = view.height;
  const double f = view_focal(view.width, view.height);
  c.K = {f, 0, view.width / 2.0, 0, f, view.height / 2.0, 0, 0, 1};
  c.R = {x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]};
  c.t = {-dot(x, position), -dot(y, position), -dot(z, position)};
  return c;
}

}  // namespace handscs
