#include "fit/multiview_capture.h"

#include <cmath>
#include <filesystem>

#include "core/camera_checks.h"
#include "core/config.h"
#include "core/image_header.h"
#include "core/vec3.h"
#include "hand/keypoint_order.h"
#include "io/npz.h"

namespace handscs {

namespace fs = std::filesystem;

namespace {

// OpenCV's pixel centres (integers) -> the project's (half-integers).
constexpr double kOpenCvToProjectPixel = 0.5;
// Skew a decomposed projection may show from its stored digits (6-8 significant) before the camera
// counts as skewed: far below a pixel over any image.
constexpr double kMaxSkewPerFocal = 1e-4;

std::string first_existing(const std::string& root, const std::vector<std::string>& names) {
  for (const auto& name : names)
    if (fs::exists(fs::path(root) / name)) return (fs::path(root) / name).string();
  return "";
}

// "<dir>/NN.png" or "<dir>/NNN.png" for view i.
std::string numbered_file(const std::string& dir, int i, const std::string& extension) {
  if (dir.empty()) return "";
  for (int digits : {2, 3, 6}) {
    std::string number = std::to_string(i);
    if (static_cast<int>(number.size()) < digits) number = std::string(digits - number.size(), '0') + number;
    const fs::path p = fs::path(dir) / (number + extension);
    if (fs::exists(p)) return p.string();
  }
  return "";
}

const NpyArray* find_array(const std::map<std::string, NpyArray>& arrays, const std::string& name) {
  auto it = arrays.find(name);
  return it == arrays.end() ? nullptr : &it->second;
}

// The top-left rows x cols block of a 3x3, 3x4 or 4x4 array.
std::vector<double> block(const NpyArray& a, int rows, int cols, const std::string& where) {
  if (a.shape.size() != 2 || a.shape[0] < rows || a.shape[1] < cols)
    throw Error(where + ": expected at least a " + std::to_string(rows) + "x" + std::to_string(cols) + " matrix");
  std::vector<double> out;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) out.push_back(a.values[r * a.shape[1] + c]);
  for (double v : out)
    if (!std::isfinite(v)) throw Error(where + ": non-finite value");
  return out;
}

std::vector<Detection> read_landmarks(const std::string& path, int view, int width, int height) {
  const json doc = parse_json_file(path);
  if (!doc.is_object()) throw Error(path + ": expected an object {\"Left\": [...], \"Right\": [...]}");
  std::vector<Detection> out;
  for (const auto& [label, values] : doc.items()) {
    if (label != "Left" && label != "Right")
      throw Error(path + ": unknown key \"" + label + "\" (known: Left, Right)");
    if (!values.is_array()) throw Error(path + ": " + label + ": expected an array");
    if (values.empty()) continue;
    if (values.size() != 63)
      throw Error(path + ": " + label + ": expected 63 numbers (21 landmarks x 3), got " +
                  std::to_string(values.size()));
    Detection d;
    d.view = view;
    d.label = label;
    for (int j = 0; j < 21; ++j) {
      const int src = kMano21FromMediaPipe[j];
      const json& x = values[3 * src];
      const json& y = values[3 * src + 1];
      if (!x.is_number() || !y.is_number()) continue;  // a missing landmark
      d.pixels[j] = {(x.get<double>() + 1.0) * 0.5 * width, (y.get<double>() + 1.0) * 0.5 * height};
      d.valid[j] = std::isfinite(d.pixels[j][0]) && std::isfinite(d.pixels[j][1]) ? 1 : 0;
    }
    out.push_back(d);
  }
  return out;
}

}  // namespace

Camera camera_from_projection(const double* P, int width, int height, const std::string& where) {
  Vec3 m1{P[0], P[1], P[2]}, m2{P[4], P[5], P[6]}, m3{P[8], P[9], P[10]};
  Vec3 p4{P[3], P[7], P[11]};
  // The overall scale's sign: det(K R) > 0 for a camera in front of its points.
  const double det = dot(m1, cross(m2, m3));
  if (!(std::fabs(det) > 1e-12 * std::pow(norm(m1) * norm(m2) * norm(m3) + 1e-300, 1.0)))
    throw Error(where + ": the projection's left 3x3 block is singular: no camera");
  if (det < 0) {
    m1 = m1 * -1.0;
    m2 = m2 * -1.0;
    m3 = m3 * -1.0;
    p4 = p4 * -1.0;
  }
  // RQ by Gram-Schmidt from the last row: M = K R with rows r1, r2, r3 of R.
  const double k22 = norm(m3);
  const Vec3 r3 = m3 * (1.0 / k22);
  const double k12 = dot(m2, r3);
  const Vec3 m2o = m2 - r3 * k12;
  const double k11 = norm(m2o);
  const Vec3 r2 = m2o * (1.0 / k11);
  const double k02 = dot(m1, r3), k01 = dot(m1, r2);
  const Vec3 m1o = m1 - r3 * k02 - r2 * k01;
  const double k00 = norm(m1o);
  const Vec3 r1 = m1o * (1.0 / k00);
  Camera cam;
  cam.K = {k00 / k22, k01 / k22, k02 / k22, 0, k11 / k22, k12 / k22, 0, 0, 1};
  cam.R = {r1[0], r1[1], r1[2], r2[0], r2[1], r2[2], r3[0], r3[1], r3[2]};
  // p4 = s K t: t = (s K)^-1 p4 by back substitution on the unnormalised K.
  const double t3 = p4[2] / k22;
  const double t2 = (p4[1] - k12 * t3) / k11;
  const double t1 = (p4[0] - k01 * t2 - k02 * t3) / k00;
  cam.t = {t1, t2, t3};
  cam.width = width;
  cam.height = height;
  return cam;
}

MultiviewCapture read_multiview_capture(const std::string& root) {
  MultiviewCapture cap;
  cap.root = root;
  const std::string archive =
      first_existing(root, {"camera/param.npz", "cameras.npz", "cameras_sphere.npz", "param.npz"});
  if (archive.empty())
    throw Error(root + ": no camera archive (camera/param.npz, cameras.npz or cameras_sphere.npz)");
  const auto arrays = read_npz(archive);
  const std::string image_dir = first_existing(root, {"img", "image", "images"});
  const std::string mask_dir = first_existing(root, {"mask", "masks"});
  const std::string pose_dir = first_existing(root, {"pose", "landmarks"});
  for (int i = 0;; ++i) {
    const std::string id = std::to_string(i);
    const NpyArray* intr = find_array(arrays, "int_" + id);
    const NpyArray* extr = find_array(arrays, "ext_" + id);
    const NpyArray* world = find_array(arrays, "world_mat_" + id);
    if (!world && !(intr && extr)) {
      if (i == 0) throw Error(archive + ": no int_0/ext_0 or world_mat_0 (is this a NeuS/IDR camera archive?)");
      break;
    }
    const std::string image = numbered_file(image_dir, i, ".png").empty()
                                  ? numbered_file(image_dir, i, ".jpg")
                                  : numbered_file(image_dir, i, ".png");
    if (image.empty()) throw Error(root + ": view " + id + " has a camera but no image in " + image_dir);
    const ImageHeaderSize size = image_header_size(read_image_bytes(image));
    if (!size.known) throw Error(image + ": not a PNG or JPEG image");
    Camera cam;
    const std::string where = archive + ": view " + id;
    if (intr && extr) {
      const auto K = block(*intr, 3, 3, archive + ": int_" + id);
      const auto E = block(*extr, 3, 4, archive + ": ext_" + id);
      for (int e = 0; e < 9; ++e) cam.K[e] = K[e] / K[8];
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) cam.R[3 * r + c] = E[4 * r + c];
        cam.t[r] = E[4 * r + 3];
      }
      cam.width = static_cast<int>(size.width);
      cam.height = static_cast<int>(size.height);
    } else {
      const auto P = block(*world, 3, 4, archive + ": world_mat_" + id);
      cam = camera_from_projection(P.data(), static_cast<int>(size.width), static_cast<int>(size.height), where);
    }
    cam.K[2] += kOpenCvToProjectPixel;
    cam.K[5] += kOpenCvToProjectPixel;
    // A decomposed world_mat carries rounding-level skew; the project's cameras have none.
    if (std::fabs(cam.K[1]) > kMaxSkewPerFocal * cam.K[0])
      throw Error(where + ": the camera has skew " + std::to_string(cam.K[1]) + " (not a pinhole camera)");
    cam.K[1] = 0.0;
    for (const std::string& problem :
         {pinhole_matrix_problem(cam.K), rotation_problem(cam.R), camera_intrinsics_problem(cam)})
      if (!problem.empty()) throw Error(where + ": " + problem);
    cap.views.push_back(i < 10 ? "0" + id : id);
    cap.cameras.push_back(cam);
    cap.images.push_back(image);
    cap.masks.push_back(numbered_file(mask_dir, i, ".png"));
    const std::string landmarks = numbered_file(pose_dir, i, ".json");
    if (!landmarks.empty())
      for (Detection& d : read_landmarks(landmarks, i, cam.width, cam.height)) cap.detections.push_back(d);
  }
  return cap;
}

}  // namespace handscs
