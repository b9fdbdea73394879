// The result of an evaluation run: one entry per image (scores or a failure reason), the summary
// over the scored images (and per region, when region masks were scored), and its JSON / CSV /
// text-table forms. Failed images never enter a mean; nor do empty regions enter a region's mean.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "metrics/image_scorer.h"
#include "metrics/region_masks.h"

namespace handscs {

struct EvalEntry {
  std::string name;        // pairing key (file stem in folder mode)
  nlohmann::json sources;  // where the images came from, e.g. {"pred": path, "gt": path}
  int64_t width = 0;       // image size (0 when unknown)
  int64_t height = 0;
  bool ok = false;         // scored; otherwise `error` says why not
  ImageScores scores;
  std::string error;
};

// One region over the scored images where it is not empty (RegionScores of each).
struct RegionSummary {
  std::string name;
  int64_t images = 0;                // scored images where the region has pixels
  int64_t ssim_images = 0;           // of those, images with a region SSIM (see RegionScores)
  double pixel_fraction = 0;         // mean over every scored image of the region's pixel share
  std::optional<double> psnr;        // mean of per-image region PSNR (infinite when one image
                                     // matches exactly in the region, as small regions do)
  std::optional<double> psnr_pooled; // PSNR of the mean region MSE: what the tables print
  std::optional<double> mse;         // mean region MSE
  std::optional<double> ssim;        // mean region SSIM
  std::optional<double> lpips;       // mean region LPIPS (empty when skipped)
};

struct EvalSummary {
  int64_t num_entries = 0;             // scored + failed
  int64_t num_scored = 0;
  int64_t num_failed = 0;
  std::optional<double> psnr;          // mean of per-image PSNR
  std::optional<double> psnr_pooled;   // PSNR of the mean MSE
  std::optional<double> mse;           // mean MSE
  std::optional<double> ssim;          // mean SSIM
  std::optional<double> lpips;         // mean LPIPS (empty when skipped)
  std::vector<RegionSummary> regions;  // one per EvalReport::regions
};

struct EvalReport {
  std::string mode;               // "folder" (later also "model")
  nlohmann::json inputs;          // what was evaluated (directories, ...)
  nlohmann::json config;          // the resolved EvalConfig
  std::string lpips_skip_reason;  // "" when LPIPS ran
  std::vector<RegionSpec> regions;  // legend of the scored regions (empty = none); entries'
                                    // scores.regions follow its order
  std::vector<EvalEntry> entries;

  EvalSummary summary() const;
};

// {"mode", "inputs", "config", "lpips": {"enabled", "skipped_reason"}, "summary", "images",
//  "failed"}, plus with regions "regions": {name: {"bit", "description", "images", "ssim_images",
//  "pixel_fraction", "psnr", "psnr_pooled_mse", "mse", "ssim", "lpips"}} and each image's
//  "regions": {name: {"pixels", "fraction", "psnr", "ssim", "lpips", "mse"}} (null scores where the
//  region is empty). Non-finite numbers are strings: "inf" (the PSNR of identical images), "-inf",
//  "nan".
nlohmann::json eval_report_to_json(const EvalReport& report);

// One row per entry: name,status,psnr,ssim,lpips,mse,[<region>_psnr,<region>_ssim,<region>_lpips,
// <region>_fraction per region,]width,height,error (empty cells for null and for empty regions).
std::string eval_report_to_csv(const EvalReport& report);

// Human-readable table: per-image rows, the mean row, the regions (PSNR of their pooled MSE, SSIM
// and LPIPS means), the failures and the LPIPS note.
std::string format_eval_table(const EvalReport& report);

// A score as the tables print it: `digits` decimals, "inf" for an infinite PSNR (an exact match),
// "n/a" where there is none (LPIPS skipped, a region empty in every image), "nan" never hidden.
std::string score_text(const std::optional<double>& score, int digits);

// Writes the JSON (and the CSV when csv_path is not empty) atomically, creating parent folders.
void write_eval_outputs(const EvalReport& report, const std::string& json_path,
                        const std::string& csv_path);

}  // namespace handscs
