#include "data/neus_cameras.h"

#include <spdlog/spdlog.h>

#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>

#include "core/camera_checks.h"
#include "core/error.h"
#include "core/image_header.h"
#include "core/text.h"
#include "core/vec3.h"
#include "io/npz.h"

namespace handscs {

namespace fs = std::filesystem;

namespace {

// OpenCV's pixel centres (integers) -> the project's (half-integers).
constexpr double kOpenCvToProjectPixel = 0.5;
// Skew a decomposed projection may show from its stored digits (6-8 significant) before the camera
// counts as skewed: far below a pixel over any image.
constexpr double kMaxSkewPerFocal = 1e-4;
// world_mat_i against int_i @ ext_i when an archive holds both (FMHR's): relative to the focal
// length for K, absolute for R and for t over its norm (plus 1 m); 6-8 stored digits stay within.
constexpr double kAgreement = 1e-4;

const char* const kArchiveNames[] = {"camera/param.npz", "cameras.npz", "cameras_sphere.npz"};

std::string first_existing(const std::string& root, const std::vector<std::string>& names) {
  std::error_code ec;
  for (const auto& name : names)
    if (fs::exists(fs::path(root) / name, ec)) return (fs::path(root) / name).string();
  return "";
}

// The index of "<prefix><digits>" ("world_mat_12" -> 12), else -1 ("world_mat_inv_3", "scale_mat_0"
// under another prefix).
int key_index(const std::string& key, const std::string& prefix) {
  if (key.compare(0, prefix.size(), prefix) != 0 || key.size() == prefix.size() || key.size() > prefix.size() + 6)
    return -1;
  for (size_t c = prefix.size(); c < key.size(); ++c)
    if (!std::isdigit(static_cast<unsigned char>(key[c]))) return -1;
  return std::stoi(key.substr(prefix.size()));
}

// The top-left rows x cols block of a 3x3, 3x4 or 4x4 array; `where` names it in errors.
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

std::string view_name(int i) { return i < 10 ? "0" + std::to_string(i) : std::to_string(i); }

// The camera of int_i and ext_i (K scaled to K[2][2] = 1).
Camera camera_from_int_ext(const NpyArray& intr, const NpyArray& extr, const std::string& archive,
                           const std::string& id) {
  const auto K = block(intr, 3, 3, archive + ": int_" + id);
  const auto E = block(extr, 3, 4, archive + ": ext_" + id);
  if (!(K[8] != 0.0)) throw Error(archive + ": int_" + id + ": K[2][2] is 0: not an intrinsic matrix");
  Camera cam;
  for (int e = 0; e < 9; ++e) cam.K[e] = K[e] / K[8];
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) cam.R[3 * r + c] = E[4 * r + c];
    cam.t[r] = E[4 * r + 3];
  }
  return cam;
}

// "" when a and b are the same camera within kAgreement, else the largest difference.
std::string disagreement(const Camera& a, const Camera& b) {
  for (int e = 0; e < 9; ++e)
    if (std::fabs(a.K[e] - b.K[e]) > kAgreement * a.K[0])
      return "K[" + std::to_string(e / 3) + "][" + std::to_string(e % 3) + "] " + std::to_string(a.K[e]) +
             " against " + std::to_string(b.K[e]);
  for (int e = 0; e < 9; ++e)
    if (std::fabs(a.R[e] - b.R[e]) > kAgreement)
      return "R[" + std::to_string(e / 3) + "][" + std::to_string(e % 3) + "] " + std::to_string(a.R[e]) +
             " against " + std::to_string(b.R[e]);
  const double scale = 1.0 + std::sqrt(a.t[0] * a.t[0] + a.t[1] * a.t[1] + a.t[2] * a.t[2]);
  for (int r = 0; r < 3; ++r)
    if (std::fabs(a.t[r] - b.t[r]) > kAgreement * scale)
      return "t[" + std::to_string(r) + "] " + std::to_string(a.t[r]) + " against " + std::to_string(b.t[r]);
  return "";
}

// Image files of `dir` named by a number only ("07.png", "007.jpg"), by that number.
std::map<int, std::string> numbered_images(const std::string& dir) {
  std::map<int, std::string> out;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string stem = entry.path().stem().string(), ext = entry.path().extension().string();
    if (ext != ".png" && ext != ".jpg") continue;
    if (stem.empty() || stem.size() > 6) continue;
    bool digits = true;
    for (char c : stem) digits = digits && std::isdigit(static_cast<unsigned char>(c));
    if (digits) out.emplace(std::stoi(stem), entry.path().string());
  }
  return out;
}

}  // namespace

std::string find_neus_camera_archive(const std::string& root) {
  return first_existing(root, {std::begin(kArchiveNames), std::end(kArchiveNames)});
}

std::string find_neus_image_folder(const std::string& dir) {
  return first_existing(dir, {"img", "image", "images"});
}

std::string neus_view_file(const std::string& dir, int i, const std::string& extension) {
  if (dir.empty()) return "";
  std::error_code ec;
  for (int digits : {2, 3, 6}) {
    std::string number = std::to_string(i);
    if (static_cast<int>(number.size()) < digits) number = std::string(digits - number.size(), '0') + number;
    const fs::path p = fs::path(dir) / (number + extension);
    if (fs::exists(p, ec)) return p.string();
  }
  return "";
}

Camera camera_from_projection(const double* P, int width, int height, const std::string& where) {
  Vec3 m1{P[0], P[1], P[2]}, m2{P[4], P[5], P[6]}, m3{P[8], P[9], P[10]};
  Vec3 p4{P[3], P[7], P[11]};
  for (int e = 0; e < 12; ++e)
    if (!std::isfinite(P[e])) throw Error(where + ": non-finite value");
  // The overall scale's sign: det(K R) > 0 for a camera in front of its points. 1e-12 of the rows'
  // norms' product is far below any camera's (a 1e-3 focal length in units of the image side).
  const double det = dot(m1, cross(m2, m3));
  if (!(std::fabs(det) > 1e-12 * norm(m1) * norm(m2) * norm(m3)))
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

NeusViews read_neus_views(const std::string& root, const std::string& frame_dir) {
  const std::string& folder = frame_dir.empty() ? root : frame_dir;
  NeusViews out;
  out.archive = find_neus_camera_archive(root);
  const std::string& archive = out.archive;
  if (archive.empty())
    throw Error(root + ": no camera archive (camera/param.npz, cameras.npz or cameras_sphere.npz)");
  const auto arrays = read_npz(archive);
  std::set<int> indices;
  for (const auto& [key, array] : arrays)
    for (const char* prefix : {"world_mat_", "int_", "ext_"})
      if (key_index(key, prefix) >= 0) indices.insert(key_index(key, prefix));
  if (indices.empty())
    throw Error(archive + ": no world_mat_<i> or int_<i>/ext_<i> (is this a NeuS/IDR camera archive?)");
  out.image_dir = find_neus_image_folder(folder);
  if (out.image_dir.empty()) throw Error(folder + ": no image folder (img/ or image/) for " + archive);
  const std::string mask_dir = first_existing(folder, {"mask", "masks"});
  const auto images = numbered_images(out.image_dir);
  for (const auto& [number, image] : images)
    if (!indices.count(number))
      throw Error(image + ": image of view " + std::to_string(number) + ", but " + archive + " has no world_mat_" +
                  std::to_string(number) + " (nor int_" + std::to_string(number) + " and ext_" +
                  std::to_string(number) + ")");
  for (int i : indices) {
    const std::string id = std::to_string(i);
    auto find = [&](const std::string& name) -> const NpyArray* {
      auto it = arrays.find(name + id);
      return it == arrays.end() ? nullptr : &it->second;
    };
    const NpyArray* intr = find("int_");
    const NpyArray* extr = find("ext_");
    const NpyArray* world = find("world_mat_");
    if (!world && !(intr && extr))
      throw Error(archive + ": " + (intr ? "int_" + id + " without ext_" : "ext_" + id + " without int_") + id +
                  " (and no world_mat_" + id + ")");
    auto image = images.find(i);
    if (image == images.end()) {
      spdlog::warn("{}: view {} has a camera but no image in {}: left out", archive, id, out.image_dir);
      continue;
    }
    const ImageHeaderSize size = image_header_size(read_image_bytes(image->second));
    if (!size.known) throw Error(image->second + ": not a PNG or JPEG image");
    NeusView view;
    view.index = i;
    view.name = view_name(i);
    view.image = image->second;
    view.mask = neus_view_file(mask_dir, i, ".png");
    Camera& cam = view.camera;
    if (world) {
      view.where = archive + ": world_mat_" + id;
      const auto P = block(*world, 3, 4, view.where);
      cam = camera_from_projection(P.data(), 0, 0, view.where);
      if (intr && extr) {
        const std::string differ = disagreement(cam, camera_from_int_ext(*intr, *extr, archive, id));
        if (!differ.empty())
          throw Error(view.where + ": disagrees with int_" + id + " @ ext_" + id + ": " + differ);
      }
    } else {
      view.where = archive + ": int_" + id;
      cam = camera_from_int_ext(*intr, *extr, archive, id);
    }
    cam.width = static_cast<int>(size.width);
    cam.height = static_cast<int>(size.height);
    cam.K[2] += kOpenCvToProjectPixel;
    cam.K[5] += kOpenCvToProjectPixel;
    // A decomposed world_mat carries rounding-level skew; the project's cameras have none.
    if (std::fabs(cam.K[1]) > kMaxSkewPerFocal * cam.K[0])
      throw Error(view.where + ": the camera has skew " + std::to_string(cam.K[1]) + " (not a pinhole camera)");
    cam.K[1] = 0.0;
    for (const std::string& problem :
         {pinhole_matrix_problem(cam.K), rotation_problem(cam.R), camera_intrinsics_problem(cam)})
      if (!problem.empty())
        throw Error(view.where + " (with the " + std::to_string(cam.width) + "x" + std::to_string(cam.height) +
                    " size of " + view.image + "): " + problem);
    out.views.push_back(view);
  }
  if (out.views.empty()) throw Error(archive + ": no view has an image in " + out.image_dir);
  return out;
}

std::map<int64_t, std::string> neus_frame_folders(const std::string& root) {
  if (!find_neus_image_folder(root).empty()) return {{0, root}};
  std::error_code ec;
  std::map<int64_t, std::string> out;
  for (const auto& entry : fs::directory_iterator(root, ec)) {
    const std::string name = entry.path().filename().string();
    // Up to 9 digits: any frame number a capture holds, and std::stoll cannot overflow.
    if (!all_digits(name, 9) || !entry.is_directory(ec)) continue;
    if (find_neus_image_folder(entry.path().string()).empty()) {
      spdlog::warn("{}: a frame folder without an image folder (img/, image/ or images/): left out",
                   entry.path().string());
      continue;
    }
    const int64_t frame = std::stoll(name);
    if (!out.emplace(frame, entry.path().string()).second)
      throw Error(entry.path().string() + ": a second folder of frame " + std::to_string(frame) + " (with " +
                  out.at(frame) + ")");
  }
  if (out.empty())
    throw Error(root + ": no image folder (img/ or image/), nor frame folders holding one (<frame>/img/)");
  return out;
}

}  // namespace handscs
