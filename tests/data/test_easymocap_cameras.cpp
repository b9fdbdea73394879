// data/easymocap_cameras.h on hand-written EasyMocap files: the D_ key read when dist_ is absent
// (and dist_ winning when both are there), a 1x4 distortion vector read with k3 = 0, Rot_ accepted
// when it agrees with R_ to EasyMocap's 6 printed decimals and refused, naming the file and key,
// when it does not. References: the values written below and cv::Rodrigues.
#include <cmath>
#include <cstdio>
#include <string>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "data/easymocap_cameras.h"
#include "data_test_helpers.h"

// Catch last: LibTorch pulls in glog, whose CHECK macro would otherwise replace Catch's.
#include <catch2/catch.hpp>

using namespace handscs;

namespace {

const double kRvec[3] = {0.1, -0.2, 0.3};

std::string matrix(const std::string& key, int rows, int cols, const std::string& data) {
  return key + ": !!opencv-matrix\n   rows: " + std::to_string(rows) + "\n   cols: " +
         std::to_string(cols) + "\n   dt: d\n   data: [ " + data + " ]\n";
}

cv::Mat rotation_of_rvec() {
  cv::Mat rotation;
  cv::Rodrigues(cv::Mat(3, 1, CV_64F, const_cast<double*>(kRvec)), rotation);
  return rotation;
}

// The 3x3 rotation printed with 6 decimals, as EasyMocap writes it, plus `nudge` on its first entry.
std::string printed_rotation(double nudge) {
  const cv::Mat r = rotation_of_rvec();
  std::string data;
  for (int i = 0; i < 9; ++i) {
    char text[32];
    std::snprintf(text, sizeof(text), "%.6f", r.at<double>(i / 3, i % 3) + (i == 0 ? nudge : 0));
    data += (i ? ", " : "") + std::string(text);
  }
  return data;
}

struct Files {
  std::string intri, extri;
};

// intri.yml and extri.yml of one camera "cam0" with the given distortion keys and optional Rot_.
Files write_files(const std::string& name, const std::string& distortion, const std::string& rot) {
  const std::string dir = data_test::fresh_dir("easymocap_" + name);
  const std::string names = "%YAML:1.0\n---\nnames:\n   - \"cam0\"\n";
  Files files{dir + "/intri.yml", dir + "/extri.yml"};
  data_test::write_text(files.intri, names + matrix("K_cam0", 3, 3, "1000., 0., 320., 0., 1010., 240., 0., 0., 1.") +
                                         distortion + "H_cam0: 480\nW_cam0: 640\n");
  data_test::write_text(files.extri, names + matrix("R_cam0", 3, 1, "0.1, -0.2, 0.3") + rot +
                                         matrix("T_cam0", 3, 1, "0.01, 0.02, 1.5"));
  return files;
}

}  // namespace

TEST_CASE("easymocap cameras: D_ when dist_ is absent, a 1x4 vector with k3 = 0, dist_ before D_") {
  const Files d4 = write_files("d4", matrix("D_cam0", 1, 4, "0.1, -0.05, 0.001, 0.002"), "");
  const auto cameras = read_easymocap_cameras(d4.intri, d4.extri);
  REQUIRE(cameras.count("cam0") == 1);
  const RecordCamera& record = cameras.at("cam0");
  CHECK(record.distortion.coefficients == std::array<double, 5>{0.1, -0.05, 0.001, 0.002, 0.0});
  // K in core/camera.h's convention: OpenCV's integer pixel centres moved by half a pixel.
  CHECK(record.camera.K == std::array<double, 9>{1000, 0, 320.5, 0, 1010, 240.5, 0, 0, 1});
  CHECK(record.camera.width == 640);
  CHECK(record.camera.height == 480);
  const cv::Mat rotation = rotation_of_rvec();
  for (int i = 0; i < 9; ++i) CHECK(record.camera.R[i] == Approx(rotation.at<double>(i / 3, i % 3)).margin(1e-15));
  CHECK(record.camera.t == std::array<double, 3>{0.01, 0.02, 1.5});

  const Files both = write_files("both", matrix("dist_cam0", 1, 5, "0.3, 0.2, 0.01, 0.02, -0.1") +
                                             matrix("D_cam0", 1, 4, "0.1, -0.05, 0.001, 0.002"), "");
  CHECK(read_easymocap_cameras(both.intri, both.extri).at("cam0").distortion.coefficients ==
        std::array<double, 5>{0.3, 0.2, 0.01, 0.02, -0.1});

  const Files neither = write_files("neither", "", "");
  CHECK(data_test::error_of([&] { read_easymocap_cameras(neither.intri, neither.extri); }) ==
        neither.intri + ": dist_cam0: missing key");
}

TEST_CASE("easymocap cameras: Rot_ agreeing with R_ to 6 decimals is read; one off by 2e-4 names the file and key") {
  const std::string dist = matrix("dist_cam0", 1, 5, "0, 0, 0, 0, 0");
  const Files agreeing = write_files("rot_ok", dist, matrix("Rot_cam0", 3, 3, printed_rotation(0)));
  const auto cameras = read_easymocap_cameras(agreeing.intri, agreeing.extri);
  // R comes from R_ (Rodrigues), not from the printed Rot_.
  const cv::Mat rotation = rotation_of_rvec();
  for (int i = 0; i < 9; ++i)
    CHECK(cameras.at("cam0").camera.R[i] == Approx(rotation.at<double>(i / 3, i % 3)).margin(1e-15));

  const Files off = write_files("rot_off", dist, matrix("Rot_cam0", 3, 3, printed_rotation(2e-4)));
  const std::string error = data_test::error_of([&] { read_easymocap_cameras(off.intri, off.extri); });
  CHECK(error.rfind(off.extri + ": Rot_cam0: differs from the rotation of R_cam0 by 0.0002", 0) == 0);
  CHECK(error.find("(more than 1e-4)") != std::string::npos);
}
