// Region masks in evaluation: the legend and mask files (exact errors for each kind of bad input),
// folder mode with --regions (per-region means over the images where the region is not empty, the
// JSON / CSV / table outputs) and handscs-eval's region options.
#include "metrics_test_utils.h"  // first: brings Catch2 in after torch (see there)

#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "metrics/folder_eval.h"
#include "metrics/region_masks.h"

using Catch::Matchers::WithinAbs;
using Catch::Matchers::WithinRel;

namespace {

using metrics_test::run_eval;

const char* kLegend = R"({"regions": [
  {"name": "crease", "bit": 1, "description": "creases"},
  {"name": "contact", "bit": 2, "description": "contact"},
  {"name": "shadow", "bit": 4, "description": "cast shadows"}], "dilation_px": 1})";

std::string write_legend(const std::string& dir, const std::string& text) {
  handscs::ensure_directory(dir);
  const std::string path = dir + "/regions.json";
  std::ofstream(path) << text;
  return path;
}

using metrics_test::random_hwc;
using metrics_test::write_png;

// A folder-mode set of two 64x80 pairs (large enough for AlexNet's taps), a and b: crease (bit 1)
// is rows 2-9 in a and empty in b,
// contact (bit 2) is the whole of b and empty in a, shadow (bit 4) is empty everywhere; bit 8 (not
// in the legend) is set in a corner of a and must be ignored.
struct RegionFolders {
  std::string pred, gt, regions;
};

RegionFolders make_region_folders(const std::string& name) {
  const auto root = metrics_test::temp_dir(name);
  RegionFolders f{root + "/pred", root + "/gt", root + "/regions"};
  handscs::ensure_directory(f.pred);
  handscs::ensure_directory(f.gt);
  write_legend(f.regions, kLegend);
  for (const std::string image : {"a", "b"}) {
    const auto gt = random_hwc(64, 80, image == "a" ? 1 : 2);
    write_png(f.gt + "/" + image + ".png", gt);
    write_png(f.pred + "/" + image + ".png", (gt + 0.1 * (random_hwc(64, 80, 3) - 0.5)).clamp(0, 1));
    cv::Mat bits(64, 80, CV_8UC1, cv::Scalar(image == "a" ? 0 : 2));
    if (image == "a") {
      bits.rowRange(2, 10).setTo(1);
      bits.at<uint8_t>(0, 0) = 8;
    }
    REQUIRE(cv::imwrite(f.regions + "/" + image + ".png", bits));
  }
  return f;
}

// The whitespace-separated cells of the first line of `table` that starts with `name` (none: {}).
std::vector<std::string> table_cells(const std::string& table, const std::string& name) {
  std::istringstream lines(table);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind(name + " ", 0) != 0) continue;
    std::istringstream cells(line);
    std::vector<std::string> out;
    for (std::string cell; cells >> cell;) out.push_back(cell);
    return out;
  }
  return {};
}


}  // namespace

TEST_CASE("the region legend is read in file order with its names and bits", "[regions]") {
  const auto path = write_legend(metrics_test::temp_dir("legend_ok"), kLegend);
  const auto legend = handscs::read_region_legend(path);
  CHECK(legend.path == path);
  REQUIRE(legend.regions.size() == 3);
  CHECK(legend.regions[0].name == "crease");
  CHECK(legend.regions[1].bit == 2);
  CHECK(legend.regions[2].description == "cast shadows");
  // Bits decode independently, so regions may overlap; bit 8 is in no region.
  const auto bits = torch::tensor({0, 1, 2, 3, 4, 7, 8, 255}, torch::kUInt8).view({2, 4});
  const auto planes = handscs::region_planes(bits, legend);
  REQUIRE(planes.sizes() == at::IntArrayRef({3, 2, 4}));
  CHECK(at::equal(planes[0].flatten(), torch::tensor({0, 1, 0, 1, 0, 1, 0, 1}).to(torch::kBool)));
  CHECK(at::equal(planes[1].flatten(), torch::tensor({0, 0, 1, 1, 0, 1, 0, 1}).to(torch::kBool)));
  CHECK(at::equal(planes[2].flatten(), torch::tensor({0, 0, 0, 0, 1, 1, 0, 1}).to(torch::kBool)));
}

TEST_CASE("a missing or malformed region legend is an error naming the file and key", "[regions]") {
  const auto dir = metrics_test::temp_dir("legend_bad");
  auto error = [&](const std::string& text) {
    const auto path = write_legend(dir, text);
    return metrics_test::error_of([&] { handscs::read_region_legend(path); });
  };
  const std::string p = dir + "/regions.json: ";
  CHECK(metrics_test::error_of([&] { handscs::read_region_legend(dir + "/none.json"); }) ==
        dir + "/none.json: region legend not found");
  CHECK(error(R"({"regions": [)") ==
        p + "malformed JSON at line 1, column 14 (" +
            "[json.exception.parse_error.101] parse error at line 1, column 14: syntax error while "
            "parsing value - unexpected end of input; expected '[', '{', or a literal)");
  CHECK(error(R"({"legend": []})") == p + "regions: expected an array of {\"name\", \"bit\", \"description\"}");
  CHECK(error(R"({"regions": []})") == p + "regions: the legend names no region");
  CHECK(error(R"({"regions": ["crease"]})") ==
        p + "regions[0]: expected an object with \"name\" and \"bit\", got string");
  CHECK(error(R"({"regions": [{"name": "a b", "bit": 1}]})") ==
        p + "regions[0].name: expected a non-empty string of letters, digits, '_' or '-'");
  CHECK(error(R"({"regions": [{"name": "crease", "bit": 3}]})") ==
        p + "regions[0].bit: expected one of 1, 2, 4, 8, 16, 32, 64, 128, got 3");
  CHECK(error(R"({"regions": [{"name": "crease", "bit": 256}]})") ==
        p + "regions[0].bit: expected one of 1, 2, 4, 8, 16, 32, 64, 128, got 256");
  CHECK(error(R"({"regions": [{"name": "crease"}]})") ==
        p + "regions[0].bit: expected one of 1, 2, 4, 8, 16, 32, 64, 128, got nothing");
  CHECK(error(R"({"regions": [{"name": "crease", "bit": 1, "description": 2}]})") ==
        p + "regions[0].description: expected a string, got number");
  CHECK(error(R"({"regions": [{"name": "crease", "bit": 1}, {"name": "crease", "bit": 2}]})") ==
        p + "regions[1].name: \"crease\" is listed twice");
  CHECK(error(R"({"regions": [{"name": "crease", "bit": 1}, {"name": "shadow", "bit": 1}]})") ==
        p + "regions[1].bit: 1 is already the bit of \"crease\"");
}

TEST_CASE("region mask files must exist, be 8-bit single-channel and have the image's size", "[regions]") {
  const auto dir = metrics_test::temp_dir("region_mask_files");
  REQUIRE(cv::imwrite(dir + "/good.png", cv::Mat(16, 20, CV_8UC1, cv::Scalar(5))));
  const auto bits = handscs::load_region_mask(dir + "/good.png", 20, 16);
  CHECK(bits.sizes() == at::IntArrayRef({16, 20}));
  CHECK(bits.scalar_type() == torch::kUInt8);
  CHECK(bits.sum().item<int64_t>() == 5 * 16 * 20);
  CHECK(metrics_test::error_of([&] { handscs::load_region_mask(dir + "/good.png", 24, 16); }) ==
        dir + "/good.png: region mask is 20x16 but the image is 24x16 (width x height)");
  CHECK(metrics_test::error_of([&] { handscs::load_region_mask(dir + "/none.png", 20, 16); }) ==
        dir + "/none.png: region mask not found");
  std::ofstream(dir + "/garbage.png") << "not a png";
  CHECK(metrics_test::error_of([&] { handscs::load_region_mask(dir + "/garbage.png", 20, 16); }) ==
        dir + "/garbage.png: cannot read region mask");
  REQUIRE(cv::imwrite(dir + "/colour.png", cv::Mat(16, 20, CV_8UC3, cv::Scalar(1, 1, 1))));
  CHECK(metrics_test::error_of([&] { handscs::load_region_mask(dir + "/colour.png", 20, 16); }) ==
        dir + "/colour.png: region mask must be a single-channel 8-bit image (got 3 channels, 8-bit)");
  REQUIRE(cv::imwrite(dir + "/deep.png", cv::Mat(16, 20, CV_16UC1, cv::Scalar(1))));
  CHECK(metrics_test::error_of([&] { handscs::load_region_mask(dir + "/deep.png", 20, 16); }) ==
        dir + "/deep.png: region mask must be a single-channel 8-bit image (got 1 channel, 16-bit)");
  CHECK(handscs::region_mask_path("/data/regions/test", "Capture0/seq/cam400002/image0012.jpg") ==
        "/data/regions/test/Capture0/seq/cam400002/image0012.png");
}

TEST_CASE("folder eval scores regions, and empty regions stay out of the means", "[regions][eval]") {
  const auto f = make_region_folders("region_folder_eval");
  handscs::EvalConfig config;
  config.lpips.weights = metrics_test::lpips_alex_path();
  const auto plain = handscs::run_folder_eval({f.pred, f.gt, "", ""}, config);
  const auto report = handscs::run_folder_eval({f.pred, f.gt, "", f.regions}, config);
  REQUIRE(report.entries.size() == 2);
  INFO(report.entries[0].error << " / " << report.entries[1].error);
  REQUIRE(report.entries[0].ok);
  REQUIRE(report.entries[1].ok);
  REQUIRE(report.regions.size() == 3);
  const auto& a = report.entries[0].scores;
  const auto& b = report.entries[1].scores;
  // The full-image scores do not depend on regions.
  CHECK(a.psnr == plain.entries[0].scores.psnr);
  CHECK(a.ssim == plain.entries[0].scores.ssim);
  CHECK(*a.lpips == *plain.entries[0].scores.lpips);
  CHECK(a.regions[0].pixels == 8 * 80);
  CHECK_FALSE(b.regions[0].psnr.has_value());
  CHECK(b.regions[1].pixels == 64 * 80);
  CHECK_THAT(*b.regions[1].psnr, WithinAbs(b.psnr, 1e-10));
  CHECK_THAT(*b.regions[1].lpips, WithinRel(*b.lpips, 2e-6));
  const auto s = report.summary();
  REQUIRE(s.regions.size() == 3);
  const auto& crease = s.regions[0];
  CHECK(crease.name == "crease");
  CHECK(crease.images == 1);  // b has no crease pixel: a's values are the means
  CHECK(*crease.psnr == *a.regions[0].psnr);
  CHECK(*crease.ssim == *a.regions[0].ssim);
  CHECK(*crease.lpips == *a.regions[0].lpips);
  CHECK(crease.pixel_fraction == Approx((8.0 / 64 + 0.0) / 2).epsilon(1e-15));
  CHECK(s.regions[1].images == 1);
  CHECK(s.regions[2].images == 0);
  CHECK_FALSE(s.regions[2].psnr.has_value());

  const auto j = handscs::eval_report_to_json(report);
  CHECK(j["inputs"]["regions"] == f.regions + "/regions.json");
  CHECK(j["regions"]["crease"]["images"] == 1);
  CHECK(j["regions"]["crease"]["bit"] == 1);
  CHECK(j["regions"]["crease"]["psnr"].get<double>() == *a.regions[0].psnr);
  CHECK(j["regions"]["crease"]["pixel_fraction"].get<double>() == crease.pixel_fraction);
  CHECK(j["regions"]["shadow"]["psnr"].is_null());
  CHECK(j["regions"]["shadow"]["images"] == 0);
  CHECK(j["images"][1]["regions"]["crease"]["psnr"].is_null());
  CHECK(j["images"][1]["regions"]["crease"]["pixels"] == 0);
  CHECK(j["images"][0]["sources"]["regions"] == f.regions + "/a.png");

  const auto csv = handscs::eval_report_to_csv(report);
  const std::string header =
      "name,status,psnr,ssim,lpips,mse,crease_psnr,crease_ssim,crease_lpips,crease_fraction,"
      "contact_psnr,contact_ssim,contact_lpips,contact_fraction,shadow_psnr,shadow_ssim,shadow_lpips,"
      "shadow_fraction,width,height,error\n";
  CHECK(csv.rfind(header, 0) == 0);
  // b: no crease (empty cells, fraction 0), contact everywhere, no shadow.
  const auto b_row = csv.substr(csv.find("\nb,") + 1);
  CHECK(b_row.find("b,ok,") == 0);
  CHECK(b_row.find(",,,,0,") != std::string::npos);
  CHECK(b_row.find(",1,,,,0,80,64,\n") != std::string::npos);
  CHECK(csv.find("nan") == std::string::npos);

  const auto table = handscs::format_eval_table(report);
  CHECK(table.find("regions (over the images where the region has pixels: PSNR of their pooled MSE, SSIM and "
                   "LPIPS means):") != std::string::npos);
  const auto crease_cells = table_cells(table, "crease");
  REQUIRE(crease_cells.size() == 6);
  CHECK(crease_cells[1] == "1/2");
  CHECK(crease_cells[2] == "6.25%");
  CHECK(table_cells(table, "shadow") == std::vector<std::string>{"shadow", "0/2", "0.00%", "n/a", "n/a", "n/a"});
}

TEST_CASE("folder eval: a region that matches exactly in one image has a finite table PSNR", "[regions][eval]") {
  // a's crease rows are copied from its ground truth: its region PSNR is infinite, and so is the
  // mean over images; the PSNR of the pooled MSE (what the tables print) is 10 log10(1 / mean MSE).
  const auto f = make_region_folders("region_folder_exact");
  cv::Mat gt = cv::imread(f.gt + "/a.png", cv::IMREAD_UNCHANGED), pred = cv::imread(f.pred + "/a.png", cv::IMREAD_UNCHANGED);
  gt.rowRange(2, 10).copyTo(pred.rowRange(2, 10));
  REQUIRE(cv::imwrite(f.pred + "/a.png", pred));
  cv::Mat bits_b(64, 80, CV_8UC1, cv::Scalar(2));
  bits_b.rowRange(30, 40).setTo(3);  // b gets crease pixels too, with the prediction's noise
  REQUIRE(cv::imwrite(f.regions + "/b.png", bits_b));
  const auto report = handscs::run_folder_eval({f.pred, f.gt, "", f.regions}, handscs::EvalConfig{});
  REQUIRE(report.entries.size() == 2);
  REQUIRE(report.entries[0].ok);
  REQUIRE(report.entries[1].ok);
  CHECK(*report.entries[0].scores.regions[0].mse == 0.0);
  const double mse_b = *report.entries[1].scores.regions[0].mse;
  REQUIRE(mse_b > 0);
  const auto crease = report.summary().regions[0];
  CHECK(crease.images == 2);
  CHECK(std::isinf(*crease.psnr));
  const double pooled = 10 * std::log10(1 / ((0 + mse_b) / 2));
  CHECK_THAT(*crease.psnr_pooled, WithinAbs(pooled, 1e-9));
  char expected[32];
  std::snprintf(expected, sizeof(expected), "%.3f", pooled);
  CHECK(table_cells(handscs::format_eval_table(report), "crease").at(3) == expected);
  CHECK(handscs::eval_report_to_json(report)["regions"]["crease"]["psnr"] == "inf");
  CHECK(handscs::score_text(crease.psnr, 2) == "inf");
  CHECK(handscs::score_text(std::nullopt, 2) == "n/a");
  CHECK(handscs::score_text(std::nan(""), 2) == "nan");
  CHECK(handscs::score_text(31.0049, 2) == "31.00");
}

TEST_CASE("folder eval: a missing or bad region mask fails that image, naming the file", "[regions][eval]") {
  const auto f = make_region_folders("region_folder_bad");
  std::filesystem::remove(f.regions + "/b.png");
  auto report = handscs::run_folder_eval({f.pred, f.gt, "", f.regions}, handscs::EvalConfig{});
  CHECK(report.entries[0].ok);
  CHECK(report.entries[1].error == f.regions + "/b.png: region mask not found");
  REQUIRE(cv::imwrite(f.regions + "/b.png", cv::Mat(64, 81, CV_8UC1, cv::Scalar(0))));
  report = handscs::run_folder_eval({f.pred, f.gt, "", f.regions}, handscs::EvalConfig{});
  CHECK(report.entries[1].error == f.regions + "/b.png: region mask is 81x64 but the image is 80x64 (width x height)");
  CHECK(report.summary().regions[0].images == 1);
  std::filesystem::remove(f.regions + "/regions.json");
  CHECK(metrics_test::error_of([&] { handscs::run_folder_eval({f.pred, f.gt, "", f.regions}, {}); }) ==
        f.regions + "/regions.json: region legend not found");
}

TEST_CASE("handscs-eval --regions scores regions in folder mode and --help explains the options", "[regions][cli]") {
  const auto f = make_region_folders("region_cli");
  const auto dir = metrics_test::temp_dir("region_cli_out");
  auto run = run_eval("--pred " + f.pred + " --gt " + f.gt + " --regions " + f.regions + " --json " + dir +
                          "/out.json --csv " + dir + "/out.csv",
                      dir);
  INFO(run.output);
  CHECK(run.status == 0);
  CHECK(table_cells(run.output, "crease").size() == 6);
  const auto j = nlohmann::json::parse(handscs::read_file(dir + "/out.json"));
  CHECK(j["regions"]["contact"]["images"] == 1);
  CHECK(handscs::read_file(dir + "/out.csv").find(",crease_psnr,") != std::string::npos);
  run = run_eval("--pred " + f.pred + " --gt " + f.gt + " --regions " + f.regions + " --no-regions --json " +
                     dir + "/out.json",
                 dir);
  CHECK(run.status != 0);
  CHECK((run.output.find("--no-regions excludes --regions") != std::string::npos ||
         run.output.find("--regions excludes --no-regions") != std::string::npos));
  run = run_eval("--help", dir);
  CHECK(run.status == 0);
  CHECK(run.output.find("--regions") != std::string::npos);
  CHECK(run.output.find("--no-regions") != std::string::npos);
  CHECK(run.output.find("<capture root>/regions") != std::string::npos);
}
