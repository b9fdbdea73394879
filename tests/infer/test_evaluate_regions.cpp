// Model-mode evaluation with region masks, end to end on a copy of the tiny capture with masks
// written here: a region covering every pixel scores as the full image, a box has its area, an
// empty region stays out of the means; the JSON, CSV and Markdown outputs carry the regions; and
// missing, wrong-size or absent masks and legends give errors naming the file.
#include "catch_torch.h"

#include <fstream>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/threads.h"
#include "test_support.h"
#include "train/tiny_capture.h"
#include "infer/evaluate.h"
#include "train/trainer.h"

using Catch::Matchers::WithinAbs;
using Catch::Matchers::WithinRel;
using handscs_test::fresh_dir;

namespace fs = std::filesystem;

namespace {

// The box region: rows 100-159, columns 40-119 of every image.
constexpr int kBoxTop = 100, kBoxLeft = 40, kBoxHeight = 60, kBoxWidth = 80;

// Writes <root>/regions/: legend all (bit 1, every pixel), box (bit 2), none (bit 4, no pixel) and
// one mask per image of images/<split>/.
void write_regions(const std::string& root, const std::string& split) {
  handscs::ensure_directory(root + "/regions");
  std::ofstream(root + "/regions/regions.json") << R"({"regions": [
    {"name": "all", "bit": 1, "description": "every pixel"},
    {"name": "box", "bit": 2, "description": "a fixed rectangle"},
    {"name": "none", "bit": 4, "description": "no pixel"}]})";
  const fs::path images = fs::path(root) / "images" / split;
  for (const auto& item : fs::recursive_directory_iterator(images)) {
    if (item.path().extension() != ".jpg") continue;
    const cv::Mat image = cv::imread(item.path().string());
    cv::Mat bits(image.rows, image.cols, CV_8UC1, cv::Scalar(1));
    bits(cv::Rect(kBoxLeft, kBoxTop, kBoxWidth, kBoxHeight)).setTo(3);
    const fs::path mask = fs::path(root) / "regions" / split / fs::relative(item.path(), images);
    handscs::ensure_directory(mask.parent_path().string());
    REQUIRE(cv::imwrite(fs::path(mask).replace_extension(".png").string(), bits));
  }
}

}  // namespace

TEST_CASE("evaluate: region masks of the capture are scored and reported", "[regions]") {
  handscs::set_threads(2);
  const auto root = fresh_dir("eval_regions_capture");
  fs::copy(handscs_test::tiny_capture_dir(), root, fs::copy_options::recursive);
  auto config = handscs_test::tiny_run_config();
  config.data.root = root;
  config.train.iterations = 2;
  config.eval.lpips.weights = handscs_test::kLpipsAlexWeights;
  const auto run = fresh_dir("eval_regions_run");
  {
    handscs::Trainer trainer(config, run);
    while (trainer.iteration() < config.train.iterations) trainer.step();
    trainer.save_checkpoint();
  }
  handscs::ModelEvalOptions options;
  options.checkpoint = run;
  options.out_dir = run + "/eval_plain";
  // A capture without regions/ is evaluated as before: no region keys, columns or table groups.
  const auto plain = handscs::evaluate_avatar(config, options);
  REQUIRE(plain.report.summary().num_scored == 12);  // 3 held-out poses x 4 cameras
  CHECK_FALSE(nlohmann::json::parse(handscs::read_file(options.out_dir + "/summary.json")).contains("regions"));

  write_regions(root, config.data.split);
  options.out_dir = run + "/eval";
  const auto result = handscs::evaluate_avatar(config, options);
  const auto s = result.report.summary();
  REQUIRE(s.num_scored == 12);
  REQUIRE(s.regions.size() == 3);
  // Rendering is deterministic: the full-image scores are those of the run without regions.
  CHECK(*s.psnr == *plain.report.summary().psnr);
  CHECK(*s.lpips == *plain.report.summary().lpips);
  const auto& all = s.regions[0];
  CHECK(all.images == 12);
  CHECK(all.pixel_fraction == 1.0);
  CHECK_THAT(*all.psnr, WithinAbs(*s.psnr, 1e-9));
  CHECK_THAT(*all.ssim, WithinAbs(*s.ssim, 1e-12));
  CHECK_THAT(*all.lpips, WithinRel(*s.lpips, 2e-6));
  const auto& box = s.regions[1];
  const auto& first = result.report.entries.front();
  CHECK(box.images == 12);
  CHECK(box.pixel_fraction == Approx(double(kBoxWidth * kBoxHeight) / double(first.width * first.height)));
  CHECK(first.scores.regions[1].pixels == kBoxWidth * kBoxHeight);
  CHECK(s.regions[2].images == 0);
  CHECK_FALSE(s.regions[2].psnr.has_value());

  const auto j = nlohmann::json::parse(handscs::read_file(options.out_dir + "/summary.json"));
  CHECK(j["inputs"]["regions"] == root + "/regions/regions.json");
  CHECK(j["regions"]["box"]["images"] == 12);
  CHECK(j["regions"]["box"]["psnr"].get<double>() == *box.psnr);
  CHECK(j["regions"]["none"]["lpips"].is_null());
  CHECK(j["images"][0]["sources"]["regions"] ==
        root + "/regions/" + config.data.split + "/" + fs::path(result.report.entries[0].name).replace_extension(".png").string());
  const auto csv = handscs::read_file(options.out_dir + "/per_image.csv");
  CHECK(csv.find(",mse,all_psnr,all_ssim,all_lpips,all_fraction,box_psnr,") != std::string::npos);
  const auto table = handscs::read_file(options.out_dir + "/table.md");
  INFO(table);
  CHECK(table.find("| LPIPS ↓ | all PSNR ↑ | SSIM ↑ | LPIPS ↓ | box PSNR ↑ | SSIM ↑ | LPIPS ↓ | none PSNR ↑ | "
                   "SSIM ↑ | LPIPS ↓ | FPS (CPU) |") != std::string::npos);
  CHECK(table.find("| n/a | n/a | n/a |") != std::string::npos);  // the empty region
  // A region's PSNR column is the PSNR of its pooled MSE (finite even where one image matches).
  CHECK(table.find(" | " + handscs::score_text(box.psnr_pooled, 2) + " | " + handscs::score_text(box.ssim, 3) +
                   " | ") != std::string::npos);
  if (handscs::score_text(box.psnr, 2) != handscs::score_text(box.psnr_pooled, 2))  // not the mean
    CHECK(table.find(" | " + handscs::score_text(box.psnr, 2) + " | " + handscs::score_text(box.ssim, 3) + " | ") ==
          std::string::npos);
  CHECK(table.find("none in 0 of 12 images, 0.00% of the pixels") != std::string::npos);

  // --no-regions.
  options.regions = false;
  options.out_dir = run + "/eval_off";
  CHECK(handscs::evaluate_avatar(config, options).report.regions.empty());
  options.regions = true;

  // A wrong-size mask fails its frame, naming the file.
  const auto& frame_name = result.report.entries[3].name;
  const auto mask3 = root + "/regions/" + config.data.split + "/" + fs::path(frame_name).replace_extension(".png").string();
  REQUIRE(cv::imwrite(mask3, cv::Mat(10, 12, CV_8UC1, cv::Scalar(1))));
  options.out_dir = run + "/eval_bad";
  const auto bad = handscs::evaluate_avatar(config, options);
  CHECK(bad.report.summary().num_failed == 1);
  CHECK(bad.report.entries[3].error == mask3 + ": region mask is 12x10 but the image is " +
                                           std::to_string(first.width) + "x" + std::to_string(first.height) +
                                           " (width x height)");
  // A missing mask stops the evaluation before any rendering.
  fs::remove(mask3);
  CHECK(handscs_test::error_of([&] { handscs::evaluate_avatar(config, options); }) ==
        mask3 + ": region mask not found (1 of 12 frames have none under " + root + "/regions/" +
            config.data.split + "; --no-regions evaluates without regions)");
  // A regions folder given explicitly must hold a legend.
  options.regions_dir = root + "/elsewhere";
  CHECK(handscs_test::error_of([&] { handscs::evaluate_avatar(config, options); }) ==
        root + "/elsewhere/regions.json: region legend not found");
}
