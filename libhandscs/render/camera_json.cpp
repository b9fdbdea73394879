#include "render/camera_json.h"

#include <cmath>

#include "core/atomic_file.h"
#include "core/camera_checks.h"
#include "core/config.h"
#include "core/error.h"

namespace handscs {

namespace {

[[noreturn]] void fail(const std::string& source, const std::string& key, const std::string& problem) {
  throw Error(source + ": " + key + ": " + problem);
}

double number(const json& v, const std::string& source, const std::string& key) {
  if (!v.is_number()) fail(source, key, "expected number, got " + json_type_name(v));
  const double x = v.get<double>();
  if (!std::isfinite(x)) fail(source, key, "expected a finite number");
  return x;
}

void matrix3(const json& v, const std::string& source, const std::string& key, std::array<double, 9>& out) {
  if (!v.is_array() || v.size() != 3) fail(source, key, "expected a 3x3 array (3 rows of 3 numbers)");
  for (int r = 0; r < 3; ++r) {
    const std::string row_key = key + "[" + std::to_string(r) + "]";
    if (!v[r].is_array() || v[r].size() != 3) fail(source, row_key, "expected a row of 3 numbers");
    for (int c = 0; c < 3; ++c) out[3 * r + c] = number(v[r][c], source, row_key + "[" + std::to_string(c) + "]");
  }
}

int positive_int(const json& v, const std::string& source, const std::string& key) {
  if (!v.is_number_integer() || v.get<int64_t>() <= 0 || v.get<int64_t>() > 1000000)
    fail(source, key, "expected a positive integer, got " + v.dump());
  return int(v.get<int64_t>());
}

}  // namespace

Camera camera_from_json(const json& object, const std::string& source) {
  if (!object.is_object()) throw Error(source + ": expected a JSON object, got " + json_type_name(object));
  for (const auto& item : object.items())
    if (item.key() != "K" && item.key() != "R" && item.key() != "t" && item.key() != "width" &&
        item.key() != "height" && item.key() != "near" && item.key() != "far")
      fail(source, item.key(), "unknown key (known: K, R, t, width, height, near, far)");
  for (const char* key : {"K", "R", "t", "width", "height"})
    if (!object.contains(key)) fail(source, key, "missing");
  Camera cam;
  matrix3(object["K"], source, "K", cam.K);
  matrix3(object["R"], source, "R", cam.R);
  const json& t = object["t"];
  if (!t.is_array() || t.size() != 3) fail(source, "t", "expected an array of 3 numbers");
  for (int i = 0; i < 3; ++i) cam.t[i] = number(t[i], source, "t[" + std::to_string(i) + "]");
  cam.width = positive_int(object["width"], source, "width");
  cam.height = positive_int(object["height"], source, "height");
  if (object.contains("near")) cam.near_plane = number(object["near"], source, "near");
  if (object.contains("far")) cam.far_plane = number(object["far"], source, "far");
  if (!(cam.near_plane > 0 && cam.far_plane > cam.near_plane))
    fail(source, "near", "need 0 < near < far, got " + std::to_string(cam.near_plane) + ", " +
                             std::to_string(cam.far_plane));
  if (!(cam.K[0] > 0 && cam.K[4] > 0)) fail(source, "K", "fx and fy must be positive");
  if (cam.K[1] != 0 || cam.K[3] != 0 || cam.K[6] != 0 || cam.K[7] != 0 || cam.K[8] != 1)
    fail(source, "K", "expected [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (no skew)");
  const std::string implausible = camera_intrinsics_problem(cam);
  if (!implausible.empty()) fail(source, implausible.rfind("image", 0) == 0 ? "width" : "K", implausible);
  const std::string not_rotation = rotation_problem(cam.R);
  if (!not_rotation.empty()) fail(source, "R", not_rotation);
  return cam;
}

Camera read_camera_json(const std::string& path) {
  return camera_from_json(parse_json_file(path), path);
}

json camera_to_json(const Camera& c) {
  json j;
  j["K"] = {{c.K[0], c.K[1], c.K[2]}, {c.K[3], c.K[4], c.K[5]}, {c.K[6], c.K[7], c.K[8]}};
  j["R"] = {{c.R[0], c.R[1], c.R[2]}, {c.R[3], c.R[4], c.R[5]}, {c.R[6], c.R[7], c.R[8]}};
  j["t"] = {c.t[0], c.t[1], c.t[2]};
  j["width"] = c.width;
  j["height"] = c.height;
  j["near"] = c.near_plane;
  j["far"] = c.far_plane;
  return j;
}

void write_camera_json(const std::string& path, const Camera& camera) {
  write_file_atomic(path, camera_to_json(camera).dump(2) + "\n");
}

}  // namespace handscs
