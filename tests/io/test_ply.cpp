// 3DGS PLY reading and writing: round trips, other layouts (ascii, big-endian, other property orders and types,
// extra properties and elements), the activation conventions, exact error messages for bad files, and the
// handscs-render PLY mode end to end.
#include "catch_torch.h"  // first: torch, minus glog's CHECK, then Catch2

#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <torch/types.h>

#include "core/atomic_file.h"
#include "io/ply.h"
#include "io/ply_check.h"
#include "test_support.h"

using namespace handscs;
namespace fs = std::filesystem;

namespace {

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() / ("handscs_test_ply_" + std::to_string(::getpid()));
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
  std::string file(const std::string& name) const { return (path / name).string(); }
};

void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
}

using handscs_test::error_of;

GaussianPly random_ply(int64_t n, int64_t rest) {
  torch::manual_seed(3);
  GaussianPly g;
  g.means = torch::randn({n, 3});
  g.f_dc = torch::randn({n, 3});
  if (rest > 0) g.f_rest = torch::randn({n, rest});
  g.opacity_logits = torch::randn({n});
  g.log_scales = torch::randn({n, 3}) - 4;
  g.rotations = torch::randn({n, 4});
  return g;
}

const char* kHeaderTail =
    "property float opacity\nproperty float scale_0\nproperty float scale_1\nproperty float scale_2\n"
    "property float rot_0\nproperty float rot_1\nproperty float rot_2\nproperty float rot_3\nend_header\n";

// A binary 3DGS header with n vertices and all 17 properties (x y z f_dc_0..2 opacity scale_0..2 rot_0..3... as 14
// floats after the three normals).
std::string binary_header(int64_t n) {
  return "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(n) +
         "\nproperty float x\nproperty float y\nproperty float z\nproperty float f_dc_0\nproperty float f_dc_1\n"
         "property float f_dc_2\n" +
         kHeaderTail;
}

}  // namespace

TEST_CASE("PLY: write then read returns the same values (with and without f_rest)") {
  TempDir dir;
  for (int64_t rest : {0, 45}) {
    const GaussianPly g = random_ply(257, rest);
    write_gaussian_ply(dir.file("a.ply"), g);
    const GaussianPly r = read_gaussian_ply(dir.file("a.ply"));
    CHECK(r.size() == 257);
    CHECK(torch::equal(r.means, g.means));
    CHECK(torch::equal(r.f_dc, g.f_dc));
    CHECK(torch::equal(r.opacity_logits, g.opacity_logits));
    CHECK(torch::equal(r.log_scales, g.log_scales));
    CHECK(torch::equal(r.rotations, g.rotations));
    CHECK(r.f_rest.defined() == (rest > 0));
    if (rest > 0) CHECK(torch::equal(r.f_rest, g.f_rest));
  }
  // The file has the 3DGS reference layout: 62 floats per Gaussian with 45 f_rest, header first.
  const std::string bytes = read_file(dir.file("a.ply"));
  const size_t header = bytes.find("end_header\n") + 11;
  CHECK(bytes.size() - header == size_t(257 * 62 * 4));
  CHECK(bytes.find("property float nx\nproperty float ny\nproperty float nz\nproperty float f_dc_0") !=
        std::string::npos);
  // Zero Gaussians round-trip too.
  write_gaussian_ply(dir.file("empty.ply"), random_ply(0, 0));
  CHECK(read_gaussian_ply(dir.file("empty.ply")).size() == 0);
}

TEST_CASE("PLY: ascii, other property orders and types, extra properties and elements") {
  TempDir dir;
  const std::string text =
      "ply\nformat ascii 1.0\ncomment made by hand\nelement vertex 2\n"
      "property double rot_3\nproperty float scale_2\nproperty uchar red\nproperty float x\nproperty float y\n"
      "property float z\nproperty float f_dc_2\nproperty float f_dc_1\nproperty float f_dc_0\nproperty float f_rest_1\n"
      "property float f_rest_0\nproperty float opacity\nproperty float scale_0\nproperty float scale_1\n"
      "property float rot_0\nproperty float rot_1\nproperty float rot_2\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0.5 -3 255 1 2 3 0.3 0.2 0.1 9 8 -1.5 -1 -2 1 0 0\n"
      "  -0.5 -4 0 4 5 6 0.6 0.5 0.4 7 6 2.5 -5 -6 0 1 0 \n"
      "3 0 1 2\n";
  write_bytes(dir.file("b.ply"), text);
  const GaussianPly g = read_gaussian_ply(dir.file("b.ply"));
  REQUIRE(g.size() == 2);
  CHECK(torch::equal(g.means, torch::tensor({1.f, 2.f, 3.f, 4.f, 5.f, 6.f}).view({2, 3})));
  CHECK(torch::allclose(g.f_dc, torch::tensor({0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f}).view({2, 3})));
  CHECK(torch::equal(g.f_rest, torch::tensor({8.f, 9.f, 6.f, 7.f}).view({2, 2})));
  CHECK(torch::equal(g.opacity_logits, torch::tensor({-1.5f, 2.5f})));
  CHECK(torch::equal(g.log_scales, torch::tensor({-1.f, -2.f, -3.f, -5.f, -6.f, -4.f}).view({2, 3})));
  CHECK(torch::equal(g.rotations, torch::tensor({1.f, 0.f, 0.f, 0.5f, 0.f, 1.f, 0.f, -0.5f}).view({2, 4})));

  // Big-endian binary of the same first Gaussian with doubles.
  std::string be = "ply\nformat binary_big_endian 1.0\nelement vertex 1\n";
  const char* names[] = {"x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0",
                         "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"};
  for (const char* n : names) be += std::string("property double ") + n + "\n";
  be += "end_header\n";
  const double values[] = {1, 2, 3, 0.1, 0.2, 0.3, -1.5, -1, -2, -3, 1, 0, 0, 0.5};
  for (double v : values) {
    char b[8];
    std::memcpy(b, &v, 8);
    std::reverse(b, b + 8);
    be.append(b, 8);
  }
  write_bytes(dir.file("be.ply"), be);
  const GaussianPly h = read_gaussian_ply(dir.file("be.ply"));
  CHECK(torch::equal(h.means, torch::tensor({1.f, 2.f, 3.f}).view({1, 3})));
  CHECK(torch::equal(h.rotations, torch::tensor({1.f, 0.f, 0.f, 0.5f}).view({1, 4})));
}

TEST_CASE("PLY: activations follow the 3DGS conventions and invert") {
  GaussianPly g;
  g.f_dc = torch::tensor({0.f, 1.f, -1.f}).view({1, 3});
  g.opacity_logits = torch::tensor({0.f});
  g.log_scales = torch::tensor({0.f, std::log(0.01f), 1.f}).view({1, 3});
  CHECK(torch::allclose(ply_colors(g), torch::tensor({0.5f, float(0.5 + kShC0), float(0.5 - kShC0)}).view({1, 3})));
  CHECK(ply_opacities(g).item<float>() == 0.5f);
  CHECK(torch::allclose(ply_scales(g), torch::tensor({1.f, 0.01f, std::exp(1.f)}).view({1, 3})));
  const auto colors = torch::tensor({0.2f, 0.7f, 1.0f}).view({1, 3}), opac = torch::tensor({0.3f});
  const auto scales = torch::tensor({0.01f, 0.02f, 0.03f}).view({1, 3}), rot = torch::tensor({1.f, 0.f, 0.f, 0.f}).view({1, 4});
  const GaussianPly m = make_gaussian_ply(torch::zeros({1, 3}), colors, opac, scales, rot);
  CHECK(torch::allclose(ply_colors(m), colors, 1e-6, 1e-6));
  CHECK(torch::allclose(ply_opacities(m), opac, 1e-6, 1e-6));
  CHECK(torch::allclose(ply_scales(m), scales, 1e-6, 1e-7));
}

TEST_CASE("PLY: bad files give clear errors naming the file") {
  TempDir dir;
  const std::string p = dir.file("bad.ply");
  auto read_text = [&](const std::string& bytes) {
    write_bytes(p, bytes);
    return error_of([&] { read_gaussian_ply(p); });
  };
  CHECK(error_of([&] { read_gaussian_ply(dir.file("none.ply")); }) == dir.file("none.ply") + ": cannot open file");
  CHECK(read_text("PLY\nformat ascii 1.0\n") == p + ": not a PLY file (first line is 'PLY', expected 'ply')");
  CHECK(read_text("ply\nformat binary_middle_endian 1.0\nend_header\n") ==
        p + ": unsupported PLY format 'binary_middle_endian' (header line 2 'format binary_middle_endian 1.0')");
  CHECK(read_text("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n") ==
        p + ": truncated header (no end_header line)");
  CHECK(read_text("ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n") ==
        p + ": unknown property type 'float128' (header line 4 'property float128 x')");
  CHECK(read_text("ply\nformat ascii 1.0\nelement vertex -3\nend_header\n") ==
        p + ": malformed element line (header line 3 'element vertex -3')");
  CHECK(read_text("ply\nformat ascii 1.0\nelement face 0\nend_header\n") == p + ": no 'vertex' element in the header");
  // Missing properties are all listed.
  CHECK(read_text("ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
                  "property float z\nproperty float f_dc_0\nproperty float f_dc_2\n" +
                  std::string(kHeaderTail)) == p + ": vertex element is missing properties: f_dc_1");
  CHECK(read_text("ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\nend_header\n") ==
        p + ": vertex element is missing properties: y, z, f_dc_0, f_dc_1, f_dc_2, opacity, scale_0, scale_1, "
            "scale_2, rot_0, rot_1, rot_2, rot_3");
  // Truncated binary data: 3 vertices declared, 2.5 present.
  const std::string row(14 * 4, '\0');
  CHECK(read_text(binary_header(3) + row + row + row.substr(0, 20)) ==
        p + ": truncated data: element 'vertex' declares 3 rows (168 bytes) but only 2 complete rows follow");
  // Wrong count the other way: data left over.
  CHECK(read_text(binary_header(2) + row + row + row) ==
        p + ": 56 bytes of unexpected data after the last element (wrong element count in the header?)");
  // A count no file could hold is reported, not allocated.
  CHECK(read_text(binary_header(4000000000000LL) + row) ==
        p + ": truncated data: element 'vertex' declares 4000000000000 rows but the file has only 56 bytes of data");
  // Ascii: too few rows, too few and too many values, not a number.
  const std::string ascii_header =
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
      "property float f_dc_0\nproperty float f_dc_1\nproperty float f_dc_2\n" +
      std::string(kHeaderTail);
  const std::string line = "1 2 3 4 5 6 7 8 9 10 11 12 13 14\n";
  CHECK(read_text(ascii_header + line) ==
        p + ": truncated data: element 'vertex' declares 2 rows but the file ends after 1");
  CHECK(read_text(ascii_header + line + "1 2 3\n") ==
        p + ": line 20 (vertex 1): expected more values (missing 'f_dc_0')");
  CHECK(read_text(ascii_header + line + line.substr(0, line.size() - 1) + " 15\n") ==
        p + ": line 20 (vertex 1): more values than the header's properties ('15')");
  CHECK(read_text(ascii_header + line + "1 2 three 4 5 6 7 8 9 10 11 12 13 14\n") ==
        p + ": line 20 (vertex 1): 'three' is not a number (property 'z')");
  CHECK(read_text(ascii_header + line + line + line) ==
        p + ": unexpected data after the last element at line 21 (wrong element count in the header?)");
  // Writing inconsistent tensors is refused.
  GaussianPly g = random_ply(4, 0);
  g.rotations = torch::zeros({4, 3});
  CHECK(error_of([&] { write_gaussian_ply(p, g); }) ==
        p + ": cannot write: rotations must hold 4 x 4 values, got shape [4, 3]");
}

TEST_CASE("PLY check: undrawable Gaussians are counted by defect and left out") {
  GaussianPly g = random_ply(50, 3);
  const float nan = std::nanf(""), inf = std::numeric_limits<float>::infinity();
  g.means[3][1] = nan;
  g.means[4][0] = inf;
  g.f_dc[5][2] = nan;
  g.opacity_logits[6] = nan;
  g.opacity_logits[7] = -inf;  // opacity 0: drawable (sigmoid is defined)
  g.log_scales[8][0] = 200.0f;  // exp overflows to inf
  g.log_scales[3][2] = nan;     // a second defect of Gaussian 3
  g.rotations[9] = torch::zeros({4});
  const PlyCheck check = check_gaussian_ply(g);
  CHECK(check.total == 50);
  CHECK(check.num_drawable() == 50 - 6);  // Gaussians 3, 4, 5, 6, 8 and 9
  // Brute force: a Gaussian is drawable iff every activated value is finite and the rotation non-zero.
  for (int64_t i = 0; i < 50; ++i) {
    bool ok = std::isfinite(g.means[i].sum().item<float>()) && std::isfinite(g.f_dc[i].sum().item<float>()) &&
              !std::isnan(g.opacity_logits[i].item<float>()) &&
              std::isfinite(torch::exp(g.log_scales[i]).sum().item<float>()) &&
              g.rotations[i].abs().sum().item<float>() > 0;
    INFO("Gaussian " << i);
    CHECK(check.drawable[i].item<bool>() == ok);
  }
  CHECK(check.summary() == "6 of 50 Gaussians cannot be drawn (NaN/Inf position 2, NaN/Inf colour 1, NaN opacity 1, "
                           "NaN/Inf scale 2, zero or NaN/Inf rotation 1)");
  const GaussianPly kept = select_gaussians(g, check.drawable);
  CHECK(kept.size() == 44);
  CHECK(kept.f_rest.size(0) == 44);
  CHECK(check_gaussian_ply(kept).summary().empty());
  CHECK(check_gaussian_ply(GaussianPly{}).num_drawable() == 0);
  CHECK(check.scale_warning().empty());  // the overflowing scale is undrawable, not implausible

  // Scales of e^30 (a file whose scale_* are not log-scales): drawable, but named.
  GaussianPly huge = random_ply(10, 0);
  huge.log_scales[2][1] = 30.0f;
  huge.log_scales[7][0] = 10.0f;  // e^10 = 22026 > 1e4
  const PlyCheck named = check_gaussian_ply(huge);
  CHECK(named.num_drawable() == 10);
  CHECK(named.implausible_scales == 2);
  CHECK(named.largest_scale == Approx(std::exp(30.0)).epsilon(1e-6));
  CHECK(named.scale_warning() == "2 of 10 Gaussians have a scale above 10000 (largest 1.07e+13): are "
                                 "the file's scale_* log-scales, as 3DGS writes them?");
}

TEST_CASE("handscs-render renders a PLY from a camera file (PLY mode end to end)") {
  TempDir dir;
  const std::string bin = std::string(HANDSCS_BIN_DIR) + "/handscs-render";
  REQUIRE(fs::exists(bin));
  // One Gaussian on the optical axis 2 m away, projected to the centre of pixel (20, 10); opacity 0.6,
  // colour (1, 0.4, 0), background 0: that pixel is 0.6 * colour, alpha 0.6.
  const auto colors = torch::tensor({1.0f, 0.4f, 0.0f}).view({1, 3});
  write_gaussian_ply(dir.file("one.ply"),
                     make_gaussian_ply(torch::tensor({0.f, 0.f, 2.f}).view({1, 3}), colors, torch::tensor({0.6f}),
                                       torch::full({1, 3}, 0.02f), torch::tensor({1.f, 0.f, 0.f, 0.f}).view({1, 4})));
  write_bytes(dir.file("cam.json"),
              R"({"K": [[200, 0, 20.5], [0, 200, 10.5], [0, 0, 1]], "R": [[1, 0, 0], [0, 1, 0], [0, 0, 1]],
                  "t": [0, 0, 0], "width": 40, "height": 24})");
  const std::string cmd = bin + " --ply " + dir.file("one.ply") + " --camera " + dir.file("cam.json") + " --out " +
                          dir.file("out/rgb.png") + " --alpha " + dir.file("out/alpha.png") +
                          " --threads 2 --log-level warn";
  REQUIRE(std::system(cmd.c_str()) == 0);
  const cv::Mat rgb = cv::imread(dir.file("out/rgb.png"), cv::IMREAD_UNCHANGED);
  const cv::Mat alpha = cv::imread(dir.file("out/alpha.png"), cv::IMREAD_UNCHANGED);
  REQUIRE(rgb.rows == 24);
  REQUIRE(rgb.cols == 40);
  REQUIRE(rgb.channels() == 3);
  const cv::Vec3b centre = rgb.at<cv::Vec3b>(10, 20);  // BGR
  CHECK(int(centre[2]) == 153);                        // round(255 * 0.6 * 1.0)
  CHECK(int(centre[1]) == 61);                         // round(255 * 0.6 * 0.4) = round(61.2)
  CHECK(int(centre[0]) == 0);
  CHECK(int(alpha.at<uchar>(10, 20)) == 153);
  CHECK(int(alpha.at<uchar>(0, 0)) == 0);
  // Bad input: a missing PLY fails with a non-zero exit code.
  const std::string bad = bin + " --ply " + dir.file("missing.ply") + " --camera " + dir.file("cam.json") +
                          " --out " + dir.file("x.png") + " --log-level off";
  CHECK(std::system(bad.c_str()) != 0);
  CHECK(!fs::exists(dir.file("x.png")));
  // An all-NaN PLY, a .jpg name for PNG output and avatar-mode options fail with their reason.
  const auto run_logged = [&](const std::string& args) {
    const std::string log = dir.file("log.txt");
    const int status = std::system((bin + args + " > " + log + " 2>&1").c_str());
    return std::make_pair(WIFEXITED(status) ? WEXITSTATUS(status) : -1, read_file(log));
  };
  const std::string camera_out = " --camera " + dir.file("cam.json") + " --out ";
  auto nan_ply = random_ply(4, 0);
  nan_ply.means.fill_(std::nanf(""));
  write_gaussian_ply(dir.file("nan.ply"), nan_ply);
  auto [code, text] = run_logged(" --ply " + dir.file("nan.ply") + camera_out + dir.file("n.png"));
  CHECK(code == 1);
  CHECK(text.find(dir.file("nan.ply") + ": none of its Gaussians can be drawn (4 of 4 Gaussians cannot be drawn "
                  "(NaN/Inf position 4))") != std::string::npos);
  std::tie(code, text) = run_logged(" --ply " + dir.file("one.ply") + camera_out + dir.file("x.jpg"));
  CHECK(code == 1);
  CHECK(text.find("--out " + dir.file("x.jpg") + ": the PLY mode writes PNG images; name the file .png") !=
        std::string::npos);
  std::tie(code, text) = run_logged(" --ply " + dir.file("one.ply") + camera_out + dir.file("y.png") + " --orbit 3");
  CHECK(code == 1);
  CHECK(text.find("--orbit: avatar-mode option(s), used only with --checkpoint") != std::string::npos);
  std::tie(code, text) = run_logged(" --ply " + dir.file("one.ply") + " --checkpoint " + dir.file("none") +
                                    " --poses p.json" + camera_out + dir.file("z"));
  CHECK(code == 1);
  CHECK(text.find("--ply: PLY-scene option(s), not used with --checkpoint (avatar mode); give one mode") !=
        std::string::npos);
  // The camera turned around (the Gaussian now behind it): refused, nothing written.
  write_bytes(dir.file("away.json"),
              R"({"K": [[200, 0, 20.5], [0, 200, 10.5], [0, 0, 1]], "R": [[-1, 0, 0], [0, 1, 0], [0, 0, -1]],
                  "t": [0, 0, 0], "width": 40, "height": 24})");
  std::tie(code, text) = run_logged(" --ply " + dir.file("one.ply") + " --camera " + dir.file("away.json") +
                                    " --out " + dir.file("away.png"));
  CHECK(code == 1);
  CHECK(text.find(dir.file("away.json") + ": none of the 1 Gaussians of " + dir.file("one.ply") +
                  " is in this camera's view") != std::string::npos);
  CHECK_FALSE(fs::exists(dir.file("away.png")));
  CHECK_FALSE(fs::exists(dir.file("n.png")));
  CHECK_FALSE(fs::exists(dir.file("x.jpg")));
}
