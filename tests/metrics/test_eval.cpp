// Folder-mode evaluation (the library function handscs-eval calls): oracle pairs, the failure
// entries for each kind of bad input, masks, the LPIPS-skipped path, and the JSON/CSV outputs.
#include "metrics_test_utils.h"  // first: brings Catch2 in after torch (see there)

#include <cmath>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "metrics/eval_cli.h"
#include "metrics/folder_eval.h"
#include "metrics/image_scorer.h"
#include "metrics/psnr.h"

using Catch::Matchers::WithinAbs;

namespace {

handscs::FolderEvalInputs shared_pairs() {
  return {metrics_test::pairs_dir() + "/dist", metrics_test::pairs_dir() + "/ref", "", ""};
}

handscs::EvalConfig with_lpips() {
  handscs::EvalConfig config;
  config.lpips.weights = metrics_test::lpips_alex_path();
  return config;
}

using metrics_test::random_hwc;
using metrics_test::write_png;

}  // namespace

TEST_CASE("folder eval reproduces the oracle values on the shared pairs", "[eval][oracle]") {
  const auto report = handscs::run_folder_eval(shared_pairs(), with_lpips());
  REQUIRE(report.entries.size() == 2);
  const auto& i03 = report.entries[0];
  const auto& i04 = report.entries[1];
  REQUIRE(i03.ok);
  REQUIRE(i04.ok);
  CHECK(i03.name == "I03");
  CHECK(i03.width == 512);
  CHECK(i03.height == 384);
  CHECK_THAT(i03.scores.psnr, WithinAbs(21.11, 0.005));
  CHECK_THAT(i04.scores.psnr, WithinAbs(20.99, 0.005));
  CHECK_THAT(i03.scores.ssim, WithinAbs(0.68190, 1e-5));
  CHECK_THAT(i04.scores.ssim, WithinAbs(0.93119, 1e-5));
  REQUIRE(i03.scores.lpips);
  CHECK_THAT(*i03.scores.lpips, WithinAbs(0.7237, 1e-4));
  CHECK_THAT(*i04.scores.lpips, WithinAbs(0.2572, 1e-4));
  const auto s = report.summary();
  CHECK(s.num_scored == 2);
  CHECK(s.num_failed == 0);
  CHECK_THAT(*s.psnr, WithinAbs((i03.scores.psnr + i04.scores.psnr) / 2, 1e-12));
  CHECK_THAT(*s.psnr_pooled, WithinAbs(handscs::psnr_from_mse((i03.scores.mse + i04.scores.mse) / 2), 1e-12));
  CHECK_THAT(*s.ssim, WithinAbs((i03.scores.ssim + i04.scores.ssim) / 2, 1e-15));
  CHECK_THAT(*s.lpips, WithinAbs((*i03.scores.lpips + *i04.scores.lpips) / 2, 1e-15));
  CHECK(report.lpips_skip_reason.empty());
}

TEST_CASE("folder eval honours the ssim variant (valid and the MATLAB convention)", "[eval][oracle]") {
  handscs::EvalConfig config;
  config.ssim.variant = handscs::SsimConfig::Variant::valid;
  auto report = handscs::run_folder_eval(shared_pairs(), config);
  CHECK_THAT(report.entries[0].scores.ssim, WithinAbs(0.67317, 1e-5));
  CHECK_THAT(report.entries[1].scores.ssim, WithinAbs(0.93252, 1e-5));
  config.ssim.variant = handscs::SsimConfig::Variant::matlab;
  report = handscs::run_folder_eval(shared_pairs(), config);
  CHECK_THAT(report.entries[0].scores.ssim, WithinAbs(0.6993, 1e-4));
  CHECK_THAT(report.entries[1].scores.ssim, WithinAbs(0.9978, 1e-4));
}

TEST_CASE("folder eval without LPIPS weights reports LPIPS as null with the reason", "[eval]") {
  const auto report = handscs::run_folder_eval(shared_pairs(), handscs::EvalConfig{});
  CHECK(report.lpips_skip_reason == "no LPIPS weight file given (--lpips-weights FILE or lpips.weights)");
  CHECK_FALSE(report.entries[0].scores.lpips.has_value());
  CHECK_FALSE(report.summary().lpips.has_value());
  const auto j = handscs::eval_report_to_json(report);
  CHECK(j["summary"]["lpips"].is_null());
  CHECK(j["images"][0]["lpips"].is_null());
  CHECK(j["lpips"]["enabled"] == false);
  CHECK(j["lpips"]["skipped_reason"] == report.lpips_skip_reason);
  CHECK(handscs::format_eval_table(report).find("LPIPS skipped (reported as null)") != std::string::npos);
}

TEST_CASE("folder eval turns each bad pair into a failure entry excluded from the means", "[eval]") {
  const auto root = metrics_test::temp_dir("eval_failures");
  const auto pred = root + "/pred", gt = root + "/gt";
  handscs::ensure_directory(pred);
  handscs::ensure_directory(gt);
  const auto a_gt = random_hwc(16, 20, 1);
  write_png(gt + "/a.png", a_gt);
  write_png(pred + "/a.png", (a_gt + 0.05).clamp(0, 1));                  // fine
  write_png(gt + "/b.png", random_hwc(16, 24, 2));
  write_png(pred + "/b.png", random_hwc(16, 20, 3));                      // size mismatch
  write_png(gt + "/c.png", random_hwc(16, 20, 4));                        // no prediction
  write_png(pred + "/d.png", random_hwc(16, 20, 5));                      // no ground truth
  write_png(gt + "/e.png", random_hwc(16, 20, 6));
  std::ofstream(pred + "/e.png") << "not an image";                       // unreadable
  write_png(gt + "/f.png", random_hwc(16, 20, 7));
  // Float images (PFM keeps NaN; OpenCV's float TIFF does not): a NaN, and values out of range.
  cv::Mat nan_image(16, 20, CV_32FC3, cv::Scalar(0.5, 0.5, 0.5));
  nan_image.at<cv::Vec3f>(3, 4)[1] = std::numeric_limits<float>::quiet_NaN();
  REQUIRE(cv::imwrite(pred + "/f.pfm", nan_image));
  write_png(gt + "/g.png", random_hwc(16, 20, 8));
  cv::Mat bright(16, 20, CV_32FC3, cv::Scalar(0.5, 0.5, 0.5));
  bright.at<cv::Vec3f>(0, 0)[2] = 1.5f;
  REQUIRE(cv::imwrite(pred + "/g.pfm", bright));
  write_png(gt + "/h.png", random_hwc(16, 20, 9));
  cv::Mat grey(16, 20, CV_8UC1, cv::Scalar(128));
  REQUIRE(cv::imwrite(pred + "/h.png", grey));                            // grey against colour
  write_png(gt + "/i.png", random_hwc(16, 20, 10));
  {
    std::vector<uint8_t> jpeg;
    REQUIRE(cv::imencode(".jpg", handscs::rgb_tensor_to_mat(random_hwc(16, 20, 11)), jpeg));
    std::ofstream(pred + "/i.jpg", std::ios::binary)
        .write(reinterpret_cast<const char*>(jpeg.data()), static_cast<std::streamsize>(jpeg.size() - 20));
  }                                                                       // truncated JPEG
  write_png(gt + "/j.png", random_hwc(16, 20, 12));
  std::filesystem::create_symlink("j.png", pred + "/j.png");             // a link to itself
  write_png(gt + "/k.png", random_hwc(16, 20, 13));
  {
    const std::string whole = handscs::read_file(gt + "/k.png");
    std::ofstream(pred + "/k.png", std::ios::binary) << whole.substr(0, whole.size() - 12);  // no IEND
  }                                                                       // truncated PNG
  write_png(gt + "/l.png", random_hwc(16, 20, 14));
  cv::Mat grey_rgb(16, 20, CV_8UC3, cv::Scalar(90, 90, 90));
  grey_rgb.at<cv::Vec3b>(5, 6) = cv::Vec3b(200, 200, 200);
  REQUIRE(cv::imwrite(pred + "/l.png", grey_rgb));  // grey stored as RGB (R = G = B), against colour
  std::ofstream(pred + "/notes.txt") << "ignored: not an image";

  const auto report = handscs::run_folder_eval({pred, gt, "", ""}, handscs::EvalConfig{});
  REQUIRE(report.entries.size() == 12);
  std::map<std::string, std::string> errors;
  for (const auto& entry : report.entries) errors[entry.name] = entry.ok ? "ok" : entry.error;
  CHECK(errors["a"] == "ok");
  CHECK(errors["b"] == "size mismatch: prediction 20x16, ground truth 24x16");
  CHECK(errors["c"] == "no prediction in " + pred);
  CHECK(errors["d"] == "no ground truth in " + gt);
  CHECK(errors["e"] == pred + "/e.png: cannot read image");
  CHECK(errors["f"] == "prediction has 1 non-finite values (NaN or inf)");
  CHECK(errors["g"] == "prediction has 1 values outside [0, 1] (min 0.5, max 1.5)");
  CHECK(errors["h"] == "the prediction is grey and the ground truth colour (" + pred + "/h.png, " + gt +
                           "/h.png): convert one so both match");
  CHECK(errors["i"] == pred + "/i.jpg: damaged JPEG image (truncated: the image data ends without an "
                               "end-of-image marker)");
  CHECK(errors["j"] == pred + "/j.png: cannot read image (Too many levels of symbolic links)");
  CHECK(errors["k"] == pred + "/k.png: damaged PNG image (truncated: the data ends before the IEND chunk)");
  CHECK(errors["l"] == "the prediction is grey and the ground truth colour (" + pred + "/l.png, " + gt +
                           "/l.png): convert one so both match");
  const auto s = report.summary();
  CHECK(s.num_entries == 12);
  CHECK(s.num_scored == 1);
  CHECK(s.num_failed == 11);
  CHECK(*s.psnr == report.entries[0].scores.psnr);
  CHECK(*s.ssim == report.entries[0].scores.ssim);
  const auto j = handscs::eval_report_to_json(report);
  CHECK(j["summary"]["failed"] == 11);
  CHECK(j["images"].size() == 1);
  CHECK(j["failed"].size() == 11);
  CHECK(j["failed"][0]["name"] == "b");
  CHECK(j["failed"][0]["error"] == "size mismatch: prediction 20x16, ground truth 24x16");
  const auto table = handscs::format_eval_table(report);
  CHECK(table.find("11 of 12 images failed and are excluded from the means:") != std::string::npos);
}

TEST_CASE("image checks: the range's edges, infinities and dtypes", "[eval]") {
  // The checks' one-pass common case must accept and refuse exactly what the counting path does:
  // values at the slack's edge in the image's dtype pass, the next value up or down fails, +-inf
  // and NaN fail as non-finite; float and double alike.
  const handscs::ImageScorer scorer(handscs::EvalConfig{});
  const auto gt = torch::full({16, 20, 3}, 0.5f);
  for (const auto dtype : {torch::kFloat32, torch::kFloat64}) {
    INFO("dtype " << dtype);
    const double hi = dtype == torch::kFloat32 ? double(float(1 + 1e-5)) : 1 + 1e-5;
    const double lo = dtype == torch::kFloat32 ? double(float(-1e-5)) : -1e-5;
    auto with = [&](double value) {
      auto image = torch::full({16, 20, 3}, 0.5, dtype);
      image[3][4][1] = value;
      return image;
    };
    const auto g = gt.to(dtype);
    CHECK_NOTHROW(scorer.score(with(hi), g));
    CHECK_NOTHROW(scorer.score(with(lo), g));
    const double above = dtype == torch::kFloat32 ? double(std::nextafter(float(hi), 2.0f)) : std::nextafter(hi, 2.0);
    const double below = dtype == torch::kFloat32 ? double(std::nextafter(float(lo), -2.0f)) : std::nextafter(lo, -2.0);
    CHECK_THROWS_WITH(scorer.score(with(above), g), Catch::Contains("has 1 values outside [0, 1]"));
    CHECK_THROWS_WITH(scorer.score(with(below), g), Catch::Contains("has 1 values outside [0, 1]"));
    for (const double bad : {double(INFINITY), -double(INFINITY), double(NAN)})
      CHECK_THROWS_WITH(scorer.score(with(bad), g), Catch::Contains("prediction has 1 non-finite values"));
    CHECK_THROWS_WITH(scorer.score(g, with(INFINITY)), Catch::Contains("ground truth has 1 non-finite values"));
  }
}

TEST_CASE("folder eval composites the ground truth with the mask", "[eval]") {
  const auto root = metrics_test::temp_dir("eval_mask");
  const auto pred = root + "/pred", gt = root + "/gt", masks = root + "/mask";
  for (const auto& d : {pred, gt, masks}) handscs::ensure_directory(d);
  const auto image = random_hwc(24, 24, 9);
  auto mask = torch::zeros({24, 24});
  mask.narrow(0, 4, 12).narrow(1, 6, 10).fill_(1.0);
  write_png(gt + "/x.png", image);
  write_png(pred + "/x.png", image * mask.unsqueeze(2));  // rendered on black, hand region only
  cv::Mat mask_image(24, 24, CV_8UC1);
  for (int i = 0; i < 24; ++i)
    for (int j = 0; j < 24; ++j) mask_image.at<uint8_t>(i, j) = mask[i][j].item<float>() > 0 ? 255 : 0;
  REQUIRE(cv::imwrite(masks + "/x.png", mask_image));
  const auto unmasked = handscs::run_folder_eval({pred, gt, "", ""}, handscs::EvalConfig{});
  CHECK(std::isfinite(unmasked.entries[0].scores.psnr));
  const auto masked = handscs::run_folder_eval({pred, gt, masks, ""}, handscs::EvalConfig{});
  REQUIRE(masked.entries[0].ok);
  CHECK(masked.entries[0].scores.mse == 0.0);
  CHECK(std::isinf(masked.entries[0].scores.psnr));
  CHECK(masked.entries[0].scores.ssim == Approx(1.0).epsilon(1e-12));
  CHECK(handscs::eval_report_to_json(masked)["images"][0]["psnr"] == "inf");
  // A name without a mask fails rather than being scored unmasked.
  write_png(gt + "/y.png", image);
  write_png(pred + "/y.png", image);
  const auto missing = handscs::run_folder_eval({pred, gt, masks, ""}, handscs::EvalConfig{});
  REQUIRE(missing.entries.size() == 2);
  CHECK(missing.entries[1].error == "no mask in " + masks);
  // A float mask outside [0, 1] fails too.
  cv::Mat bad_mask(24, 24, CV_32FC1, cv::Scalar(2.0));
  REQUIRE(cv::imwrite(masks + "/y.pfm", bad_mask));
  const auto bad = handscs::run_folder_eval({pred, gt, masks, ""}, handscs::EvalConfig{});
  CHECK(bad.entries[1].error == "mask values must be finite and in [0, 1]");
}

TEST_CASE("folder eval rejects missing folders, empty folders and duplicate names", "[eval]") {
  const auto root = metrics_test::temp_dir("eval_folders");
  const auto pred = root + "/pred", gt = root + "/gt";
  handscs::ensure_directory(pred);
  handscs::ensure_directory(gt);
  CHECK(metrics_test::error_of([&] { handscs::run_folder_eval({root + "/none", gt, "", ""}, {}); }) ==
        root + "/none: not a folder");
  CHECK(metrics_test::error_of([&] { handscs::run_folder_eval({pred, gt, "", ""}, {}); }) ==
        gt + ": no images (png, jpg, jpeg, bmp, tif, tiff, exr, webp, ppm, pgm, pfm)");
  write_png(gt + "/a.png", random_hwc(12, 12, 1));
  write_png(gt + "/a.JPG", random_hwc(12, 12, 1));
  CHECK(metrics_test::error_of([&] { handscs::run_folder_eval({pred, gt, "", ""}, {}); }) ==
        gt + ": two images are named \"a\" (a.JPG, a.png); keep one");
}

TEST_CASE("eval config resolves flags over --set overrides and rejects bad values", "[eval]") {
  handscs::EvalCommandLine cli;
  cli.ssim_variant = "valid";
  cli.lpips_weights = "123";  // a path that looks like a number stays a string
  auto config = handscs::resolve_eval_config(cli, {"ssim.variant=matlab", "lpips.net=vgg"});
  CHECK(config.ssim.variant == handscs::SsimConfig::Variant::valid);
  CHECK(config.lpips.weights == "123");
  CHECK(config.lpips.net == "vgg");
  cli.ssim_variant = "gauss";
  CHECK(metrics_test::error_of([&] { handscs::resolve_eval_config(cli, {}); }) ==
        "command line: ssim.variant: unknown value \"gauss\" (known: 3dgs, valid, matlab)");
  cli.ssim_variant.clear();
  CHECK(metrics_test::error_of([&] { handscs::resolve_eval_config(cli, {"background=[0,0,2]"}); }) ==
        "command line: background: values must be in [0, 1]");
  // The run config's spelling (docs/CONFIG.md: eval.background) names the same key here.
  CHECK(metrics_test::error_of([&] { handscs::resolve_eval_config(cli, {"eval.background=[2,-1,0.5]"}); }) ==
        "command line: background: values must be in [0, 1]");
  CHECK(handscs::resolve_eval_config(cli, {"eval.background=[1,1,1]"}).background ==
        std::array<double, 3>{1, 1, 1});
  handscs::EvalConfig bad;
  bad.lpips.input_range = "minus_one_one";
  CHECK(metrics_test::error_of([&] { handscs::ImageScorer{bad}; }) ==
        "lpips.input_range: evaluation images are in [0,1]; use zero_one (official) or zero_one_unscaled");
}

TEST_CASE("eval outputs are written as JSON and CSV", "[eval]") {
  const auto report = handscs::run_folder_eval(shared_pairs(), with_lpips());
  const auto dir = metrics_test::temp_dir("eval_outputs");
  handscs::write_eval_outputs(report, dir + "/sub/out.json", dir + "/out.csv");
  const auto j = nlohmann::json::parse(handscs::read_file(dir + "/sub/out.json"));
  CHECK(j["mode"] == "folder");
  CHECK(j["config"]["ssim"]["variant"] == "3dgs");
  CHECK(j["summary"]["scored"] == 2);
  CHECK_THAT(j["images"][1]["lpips"].get<double>(), WithinAbs(0.2572, 1e-4));
  const auto csv = handscs::read_file(dir + "/out.csv");
  CHECK(csv.rfind("name,status,psnr,ssim,lpips,mse,width,height,error\nI03,ok,21.11", 0) == 0);
  CHECK(std::count(csv.begin(), csv.end(), '\n') == 3);
}
