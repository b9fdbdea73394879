// Image <-> tensor conversions: BGR order, depths, gray, alpha compositing, masks, layouts.
#include "metrics_test_utils.h"  // first: brings Catch2 in after torch (see there)

#include "metrics/image_tensor.h"

#include <fstream>

#include "core/atomic_file.h"

TEST_CASE("mat_to_rgb_tensor converts BGR 8-bit to RGB in [0,1]", "[image]") {
  cv::Mat bgr(2, 3, CV_8UC3, cv::Scalar(10, 20, 255));  // B=10, G=20, R=255
  const auto rgb = handscs::mat_to_rgb_tensor(bgr);
  REQUIRE(rgb.sizes() == at::IntArrayRef({2, 3, 3}));
  CHECK(rgb.scalar_type() == torch::kFloat);
  CHECK(rgb[1][2][0].item<float>() == 1.0f);
  CHECK(rgb[1][2][1].item<float>() == Approx(20.0 / 255.0).epsilon(1e-7));
  CHECK(rgb[1][2][2].item<float>() == Approx(10.0 / 255.0).epsilon(1e-7));
}

TEST_CASE("mat_to_rgb_tensor handles gray, 16-bit, float and BGRA over the background", "[image]") {
  cv::Mat gray(1, 2, CV_8UC1, cv::Scalar(51));
  const auto g = handscs::mat_to_rgb_tensor(gray);
  REQUIRE(g.sizes() == at::IntArrayRef({1, 2, 3}));
  CHECK(g[0][1][2].item<float>() == Approx(0.2).epsilon(1e-7));
  cv::Mat wide(1, 1, CV_16UC3, cv::Scalar(0, 65535, 13107));
  const auto w = handscs::mat_to_rgb_tensor(wide);
  CHECK(w[0][0][0].item<float>() == Approx(0.2).epsilon(1e-7));
  CHECK(w[0][0][1].item<float>() == 1.0f);
  cv::Mat floats(1, 1, CV_32FC3, cv::Scalar(0.25, 0.5, 0.75));
  CHECK(handscs::mat_to_rgb_tensor(floats)[0][0][0].item<float>() == 0.75f);
  // BGRA: R = 1 with alpha 0.5 over background (0, 0.5, 1) -> (0.5, 0.25, 0.5).
  cv::Mat bgra(1, 1, CV_8UC4, cv::Scalar(0, 0, 255, 0));
  bgra.at<cv::Vec4b>(0, 0)[3] = 128;
  const double a = 128.0 / 255.0;
  const auto c = handscs::mat_to_rgb_tensor(bgra, {0.0, 0.5, 1.0});
  CHECK(c[0][0][0].item<float>() == Approx(a).epsilon(1e-6));
  CHECK(c[0][0][1].item<float>() == Approx(0.5 * (1 - a)).epsilon(1e-6));
  CHECK(c[0][0][2].item<float>() == Approx(1 - a).epsilon(1e-6));
  cv::Mat two(1, 1, CV_8UC2);
  CHECK(metrics_test::error_of([&] { handscs::mat_to_rgb_tensor(two); }) ==
        "unsupported channel count 2 (need 1, 3 or 4)");
}

TEST_CASE("mat_to_mask_tensor accepts gray masks and rejects coloured ones", "[image]") {
  cv::Mat mask(2, 2, CV_8UC1, cv::Scalar(255));
  mask.at<uint8_t>(0, 1) = 0;
  const auto m = handscs::mat_to_mask_tensor(mask);
  REQUIRE(m.sizes() == at::IntArrayRef({2, 2}));
  CHECK(m[0][1].item<float>() == 0.0f);
  CHECK(m[1][1].item<float>() == 1.0f);
  cv::Mat gray3(2, 2, CV_8UC3, cv::Scalar(255, 255, 255));
  CHECK(handscs::mat_to_mask_tensor(gray3)[0][0].item<float>() == 1.0f);
  cv::Mat colour(2, 2, CV_8UC3, cv::Scalar(255, 0, 0));
  CHECK(metrics_test::error_of([&] { handscs::mat_to_mask_tensor(colour); }) ==
        "mask has colour (its channels differ); give a gray mask");
}

TEST_CASE("image files round-trip through load_rgb_image and rgb_tensor_to_mat", "[image]") {
  const auto dir = metrics_test::temp_dir("image_tensor");
  const auto rgb = metrics_test::smooth_image({1, 3, 5, 7}, 81, torch::kFloat);
  const auto hwc = handscs::bchw_to_hwc(rgb);
  REQUIRE(hwc.sizes() == at::IntArrayRef({5, 7, 3}));
  CHECK(torch::equal(handscs::hwc_to_bchw(hwc), rgb));
  const auto path = dir + "/a.png";
  REQUIRE(cv::imwrite(path, handscs::rgb_tensor_to_mat(hwc)));
  const auto loaded = handscs::load_rgb_image(path);
  CHECK((loaded - hwc).abs().max().item<float>() <= 0.5f / 255.0f + 1e-6f);
  CHECK(metrics_test::error_of([&] { handscs::load_rgb_image(dir + "/none.png"); }) ==
        dir + "/none.png: cannot read image");
}

TEST_CASE("load_rgb_image refuses a damaged JPEG with its path", "[image]") {
  const auto dir = metrics_test::temp_dir("image_tensor_jpeg");
  const auto path = dir + "/pred.jpg";
  cv::Mat image(48, 64, CV_8UC3);
  cv::randu(image, cv::Scalar(0, 0, 0), cv::Scalar(255, 255, 255));
  REQUIRE(cv::imwrite(path, image));
  CHECK(handscs::load_rgb_image(path).size(0) == 48);
  const std::string whole = handscs::read_file(path);
  std::ofstream(path, std::ios::binary | std::ios::trunc) << whole.substr(0, whole.size() / 2);
  CHECK_FALSE(cv::imread(path).empty());  // libjpeg alone decodes it, with a grey tail
  CHECK(metrics_test::error_of([&] { handscs::load_rgb_image(path); }) ==
        path + ": damaged JPEG image (truncated: the image data ends without an end-of-image marker)");
}
