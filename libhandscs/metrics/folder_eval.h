// handscs-eval folder mode: pairs prediction and ground-truth images (and masks) by file name and
// scores every pair; a pair that cannot be scored becomes a failure entry, never part of a mean.
#pragma once

#include <string>
#include <vector>

#include "metrics/eval_config.h"
#include "metrics/eval_report.h"

namespace handscs {

struct FolderEvalInputs {
  std::string pred_dir;     // predictions
  std::string gt_dir;       // ground truth
  std::string mask_dir;     // optional masks ("" = none)
  std::string regions_dir;  // optional region masks <name>.png and their regions.json ("" = none)
};

// One name present in either folder. Paths are empty where that folder has no such image.
struct ImagePair {
  std::string name;  // file name without extension
  std::string pred;
  std::string gt;
  std::string mask;
};

// Image files (png, jpg, jpeg, bmp, tif, tiff, exr, webp, ppm, pgm, pfm; any letter
// case) of `dir`
// by name without extension, sorted. Throws Error when `dir` is not a folder or two files share a name.
std::vector<std::pair<std::string, std::string>> list_images(const std::string& dir);

// Union of the names in pred_dir and gt_dir (sorted), with the mask of each name when mask_dir is
// given. Throws Error when a folder is missing or gt_dir holds no images.
std::vector<ImagePair> pair_images_by_name(const FolderEvalInputs& inputs);

// Scores every pair (and its regions with regions_dir). Missing partners, unreadable files, size
// mismatches, non-finite values and missing or bad region masks become failure entries. Logs once
// when LPIPS is skipped. Throws Error for bad folders, config or region legend.
EvalReport run_folder_eval(const FolderEvalInputs& inputs, const EvalConfig& config);

}  // namespace handscs
