#include "data/easymocap_cameras.h"

#include <filesystem>

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/persistence.hpp>

#include "core/atomic_file.h"
#include "core/camera_checks.h"
#include "core/error.h"

namespace handscs {

namespace {

// EasyMocap writes its matrices with 6 decimals: Rot_ and the rotation of R_ agree to about 1e-6.
constexpr double kRotationAgreement = 1e-4;

// One open FileStorage with its path, for errors "<file>: <key>: <problem>".
class YamlFile {
 public:
  explicit YamlFile(const std::string& path) : path_(path) {
    std::error_code ec;
    if (std::filesystem::is_regular_file(path, ec) && std::filesystem::file_size(path, ec) == 0)
      throw Error(path + ": is empty (expected OpenCV YAML: \"%YAML:1.0\", then the cameras' keys)");
    try {
      storage_.open(path, cv::FileStorage::READ);
    } catch (const cv::Exception& e) {
      throw Error(path + ": cannot parse (" + e.err + ")");  // OpenCV's message without its source
    }
    if (!storage_.isOpened()) throw Error(path + ": cannot open");
  }

  [[noreturn]] void fail(const std::string& key, const std::string& problem) const {
    throw Error(path_ + ": " + key + ": " + problem);
  }
  bool has(const std::string& key) const { return !storage_[key].empty(); }

  // The matrix at `key` as doubles: rows x cols, or for a vector (rows 0) 1 x n or n x 1 with n one
  // of `lengths`.
  cv::Mat matrix(const std::string& key, int rows, int cols) const {
    const cv::Mat m = read(key);
    if (m.rows != rows || m.cols != cols)
      fail(key, "expected a " + std::to_string(rows) + "x" + std::to_string(cols) + " matrix, got " +
                    shape(m));
    return m;
  }
  std::vector<double> vector(const std::string& key, const std::vector<int>& lengths) const {
    const cv::Mat m = read(key);
    const int n = static_cast<int>(m.total());
    bool fits = m.rows == 1 || m.cols == 1;
    bool length_ok = false;
    for (int length : lengths) length_ok = length_ok || n == length;
    if (!fits || !length_ok) {
      std::string wanted;
      for (int length : lengths) wanted += (wanted.empty() ? "" : " or ") + std::to_string(length);
      fail(key, "expected " + wanted + " numbers (an n x 1 or 1 x n matrix), got " + shape(m));
    }
    return std::vector<double>(m.begin<double>(), m.end<double>());
  }

  static std::string shape(const cv::Mat& m) {
    return std::to_string(m.rows) + "x" + std::to_string(m.cols);
  }

  cv::Mat read(const std::string& key) const {
    const cv::FileNode node = storage_[key];
    if (node.empty()) fail(key, "missing key");
    cv::Mat m;
    try {
      node >> m;
    } catch (const cv::Exception&) {
      m.release();
    }
    if (m.empty() || m.channels() != 1) fail(key, "expected an OpenCV matrix (!!opencv-matrix)");
    cv::Mat out;
    m.convertTo(out, CV_64F);
    for (auto it = out.begin<double>(); it != out.end<double>(); ++it)
      if (!std::isfinite(*it)) fail(key, "expected finite numbers");
    return out;
  }

  int integer(const std::string& key) const {
    const cv::FileNode node = storage_[key];
    if (!node.isInt()) fail(key, "expected an integer");
    return static_cast<int>(node);
  }

  std::vector<std::string> names(const std::string& key) const {
    const cv::FileNode node = storage_[key];
    if (node.empty()) fail(key, "missing key");
    if (!node.isSeq()) fail(key, "expected a list of camera names");
    std::vector<std::string> out;
    for (const auto& item : node) {
      // EasyMocap writes names quoted; unquoted numbers ("- 1") read as integers.
      std::string name = item.isString() ? std::string(item)
                         : item.isInt()  ? std::to_string(static_cast<int>(item))
                                         : std::string();
      if (name.empty()) fail(key, "expected a list of camera names");
      out.push_back(name);
    }
    if (out.empty()) fail(key, "lists no cameras");
    return out;
  }

 private:
  std::string path_;
  cv::FileStorage storage_;
};

}  // namespace

std::map<std::string, RecordCamera> read_easymocap_cameras(const std::string& intri_path,
                                                           const std::string& extri_path) {
  const YamlFile intri(intri_path), extri(extri_path);
  std::map<std::string, RecordCamera> cameras;
  for (const std::string& name : intri.names("names")) {
    if (cameras.count(name)) intri.fail("names", "camera \"" + name + "\" is listed twice");
    RecordCamera record;
    record.where = intri_path + ": K_" + name;
    Camera& camera = record.camera;
    const cv::Mat K = intri.matrix("K_" + name, 3, 3);
    for (int i = 0; i < 9; ++i) camera.K[i] = K.at<double>(i / 3, i % 3);
    const std::string not_pinhole = pinhole_matrix_problem(camera.K);
    if (!not_pinhole.empty()) intri.fail("K_" + name, not_pinhole);
    camera.K[2] += kOpenCvPixelOffset;  // EasyMocap calibrates with OpenCV's pixel centres
    camera.K[5] += kOpenCvPixelOffset;
    // EasyMocap's reader falls back to D_<name> when dist_<name> is absent.
    const std::string dist_key =
        !intri.has("dist_" + name) && intri.has("D_" + name) ? "D_" + name : "dist_" + name;
    const std::vector<double> dist = intri.vector(dist_key, {5, 4});  // k3 = 0 when 4
    for (size_t i = 0; i < dist.size(); ++i) record.distortion.coefficients[i] = dist[i];
    if (intri.has("H_" + name) || intri.has("W_" + name)) {
      camera.height = intri.integer("H_" + name);
      camera.width = intri.integer("W_" + name);
      // JPEG's largest side; a larger calibrated size is a typing error, not a camera.
      constexpr int kMaxImageSide = 65535;
      for (const auto& [key, side] : {std::pair<std::string, int>{"H_" + name, camera.height},
                                      {"W_" + name, camera.width}})
        if (side <= 0 || side > kMaxImageSide)
          intri.fail(key, "image size " + std::to_string(side) + " is not in [1, 65535] pixels");
    }
    const std::vector<double> rvec = extri.vector("R_" + name, {3});
    cv::Mat rotation;
    cv::Rodrigues(cv::Mat(rvec), rotation);
    for (int i = 0; i < 9; ++i) camera.R[i] = rotation.at<double>(i / 3, i % 3);
    if (extri.has("Rot_" + name)) {
      const cv::Mat stored = extri.matrix("Rot_" + name, 3, 3);
      const double gap = cv::norm(stored - rotation, cv::NORM_INF);
      if (gap > kRotationAgreement)
        extri.fail("Rot_" + name, "differs from the rotation of R_" + name + " by " +
                                      std::to_string(gap) + " (more than 1e-4)");
    }
    const std::vector<double> t = extri.vector("T_" + name, {3});
    for (int i = 0; i < 3; ++i) camera.t[i] = t[i];
    cameras[name] = record;
  }
  return cameras;
}

void write_easymocap_cameras(const std::map<std::string, RecordCamera>& cameras,
                             const std::string& intri_path, const std::string& extri_path) {
  cv::FileStorage intri(".yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  cv::FileStorage extri(".yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  for (cv::FileStorage* file : {&intri, &extri}) {
    *file << "names" << "[";
    for (const auto& [name, record] : cameras) *file << name;
    *file << "]";
  }
  for (const auto& [name, record] : cameras) {
    const Camera& camera = record.camera;
    intri << "K_" + name << opencv_intrinsics(camera);
    intri << "dist_" + name << cv::Mat(1, 5, CV_64F, const_cast<double*>(record.distortion.coefficients.data()));
    intri << "H_" + name << camera.height << "W_" + name << camera.width;
    cv::Mat R(3, 3, CV_64F), rvec;
    for (int i = 0; i < 9; ++i) R.at<double>(i / 3, i % 3) = camera.R[i];
    cv::Rodrigues(R, rvec);
    extri << "R_" + name << rvec << "Rot_" + name << R;
    extri << "T_" + name << cv::Mat(3, 1, CV_64F, const_cast<double*>(camera.t.data()));
  }
  write_file_atomic(intri_path, intri.releaseAndGetString());
  write_file_atomic(extri_path, extri.releaseAndGetString());
}

}  // namespace handscs
