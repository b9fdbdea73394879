// tools/study/ablation_table.py, which summarises a seeded ablation sweep: each row's mean and sample
// std over its seeds against values worked out here from made-up figures, the paper's numbers beside
// the row they belong to, a region's column read from its pooled-MSE PSNR (its mean of per-image
// PSNRs is "inf" in one run, as a region matching exactly in one image makes it), a cell that only
// some seeds have a value for saying so, and the CSV's seed count per mean.
#include <catch2/catch.hpp>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "core/atomic_file.h"
#include "test_support.h"

TEST_CASE("ablation_table.py: means, stds, the paper's row, region scores and costs") {
  const std::string dir = handscs_test::scratch_path("handscs_test_ablation_table", std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  // full: PSNR 30 and 32 (mean 31, std sqrt 2), LPIPS only on seed 1. embedding: one seed.
  handscs::write_file_atomic(dir + "/results.csv",
                             "point,budget,status,psnr,ssim,lpips,train_wall_s,peak_rss_mb\n"
                             "full.s1,400,ok,30,0.95,0.05,100,800\n"
                             "full.s2,400,ok,32,0.97,,110,820\n"
                             "embedding.s1,400,ok,29.5,0.94,0.06,90,700\n"
                             "full.s3,400,failed,,,,,\n");
  // Region "contact": pooled-MSE PSNRs 20 and 22; seed 1's mean of per-image PSNRs is infinite.
  const auto summary = [&](const std::string& point, const std::string& psnr, double pooled,
                           double ssim, double lpips) {
    const std::string eval = dir + "/runs/" + point + "_400/eval";
    std::filesystem::create_directories(eval);
    handscs::write_file_atomic(eval + "/summary.json",
                               R"({"regions": {"contact": {"psnr": )" + psnr + R"(, "psnr_pooled_mse": )" +
                                   std::to_string(pooled) + R"(, "ssim": )" + std::to_string(ssim) +
                                   R"(, "lpips": )" + std::to_string(lpips) + "}}}");
  };
  summary("full.s1", "\"inf\"", 20, 0.90, 0.10);
  summary("full.s2", "23.5", 22, 0.92, 0.12);
  summary("embedding.s1", "25.0", 24, 0.88, 0.13);
  const std::string log = dir + "/log.txt";
  REQUIRE(std::system(("/usr/bin/python3 '" + handscs_test::kSource + "/tools/study/ablation_table.py' '" + dir +
                       "' > '" + log + "' 2>&1")
                          .c_str()) == 0);
  const std::string table = handscs::read_file(dir + "/ablation.md");
  INFO(table);
  CHECK(table.find("| row | seeds | PSNR | SSIM | LPIPS | paper PSNR / SSIM / LPIPS | contact PSNR | "
                   "contact SSIM | contact LPIPS | train s | peak MB |") != std::string::npos);
  // Training time and memory: 105 ± 7 s (100 and 110), 810 ± 14 MB.
  CHECK(table.find("| full model | 2 | 31.00 ± 1.41 | 0.9600 ± 0.0141 | 0.0500 (1 of 2 seeds) | "
                   "32.91 / 0.966 / 0.0291 | 21.00 ± 1.41 | 0.9100 ± 0.0141 | 0.1100 ± 0.0141 | 105 ± 7 | "
                   "810 ± 14 |") != std::string::npos);
  CHECK(table.find("| (b) + embeddings | 1 | 29.50 | 0.9400 | 0.0600 | 32.23 / 0.961 / 0.0337 | 24.00 | "
                   "0.8800 | 0.1300 | 90 | 700 |") != std::string::npos);
  CHECK(table.find("inf") == std::string::npos);
  // The CSV says how many seeds each mean is over, and gives no std for one seed.
  const std::string csv = handscs::read_file(dir + "/ablation.csv");
  INFO(csv);
  CHECK(csv.find("row,seeds,psnr_mean,psnr_std,psnr_seeds,ssim_mean,ssim_std,ssim_seeds,lpips_mean,lpips_std,"
                 "lpips_seeds\n") == 0);
  CHECK(csv.find("\nfull,2,31.0,1.414213562373095") != std::string::npos);
  CHECK(csv.find(",0.05,,1\n") != std::string::npos);
  CHECK(csv.find("\nembedding,1,29.5,,1,0.94,,1,0.06,,1\n") != std::string::npos);
  std::filesystem::remove_all(dir);
}
