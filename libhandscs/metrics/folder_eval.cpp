#include "metrics/folder_eval.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <map>
#include <set>

#include <c10/util/Exception.h>
#include <spdlog/spdlog.h>

#include "core/config.h"
#include "core/error.h"
#include "core/progress.h"
#include "core/text.h"
#include "metrics/image_tensor.h"
#include "metrics/region_masks.h"

namespace handscs {

namespace fs = std::filesystem;

namespace {

bool is_image_file(const fs::path& path) {
  static const std::set<std::string> extensions = {".png", ".jpg", ".jpeg", ".bmp", ".tif",
                                                   ".tiff", ".exr", ".webp", ".ppm", ".pgm", ".pfm"};
  return extensions.count(lower_extension(path.string())) > 0;
}

}  // namespace

std::vector<std::pair<std::string, std::string>> list_images(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw Error(dir + ": not a folder");
  std::map<std::string, std::string> by_name;
  for (const auto& item : fs::directory_iterator(dir, ec)) {
    if (!is_image_file(item.path())) continue;
    // An image name whose status cannot be read (a link loop, a dangling link) is kept: it then
    // fails by name with its reason, where skipping it would hide it.
    std::error_code status_error;
    if (!item.is_regular_file(status_error) && !status_error) continue;
    const std::string name = item.path().stem().string();
    const std::string path = item.path().string();
    const auto [it, inserted] = by_name.emplace(name, path);
    if (!inserted) {
      const auto first = std::min(it->second, path), second = std::max(it->second, path);
      throw Error(dir + ": two images are named \"" + name + "\" (" +
                  fs::path(first).filename().string() + ", " + fs::path(second).filename().string() +
                  "); keep one");
    }
  }
  if (ec) throw Error(dir + ": cannot list folder (" + ec.message() + ")");
  return {by_name.begin(), by_name.end()};
}

std::vector<ImagePair> pair_images_by_name(const FolderEvalInputs& inputs) {
  const auto preds = list_images(inputs.pred_dir);
  const auto gts = list_images(inputs.gt_dir);
  if (gts.empty())
    throw Error(inputs.gt_dir + ": no images (png, jpg, jpeg, bmp, tif, tiff, exr, webp, ppm, pgm, pfm)");
  std::map<std::string, std::string> masks;
  if (!inputs.mask_dir.empty())
    for (const auto& [name, path] : list_images(inputs.mask_dir)) masks[name] = path;
  std::map<std::string, ImagePair> pairs;
  for (const auto& [name, path] : preds) pairs[name].pred = path;
  for (const auto& [name, path] : gts) pairs[name].gt = path;
  std::vector<ImagePair> result;
  for (auto& [name, pair] : pairs) {
    pair.name = name;
    const auto mask = masks.find(name);
    if (mask != masks.end()) pair.mask = mask->second;
    result.push_back(pair);
  }
  return result;
}

EvalReport run_folder_eval(const FolderEvalInputs& inputs, const EvalConfig& config) {
  EvalConfig resolved = config;
  EvalReport report;
  report.mode = "folder";
  report.inputs = {{"pred_dir", inputs.pred_dir}, {"gt_dir", inputs.gt_dir},
                   {"mask_dir", inputs.mask_dir.empty() ? json(nullptr) : json(inputs.mask_dir)}};
  report.config = config_to_json(resolved);
  RegionLegend legend;
  if (!inputs.regions_dir.empty()) {
    legend = read_region_legend((fs::path(inputs.regions_dir) / kRegionLegendFile).string());
    report.regions = legend.regions;
    report.inputs["regions"] = legend.path;
  }

  const auto pairs = pair_images_by_name(inputs);
  const ImageScorer scorer(config);
  report.lpips_skip_reason = scorer.lpips_skip_reason();
  if (!scorer.has_lpips()) spdlog::warn("LPIPS skipped, reported as null: {}", report.lpips_skip_reason);

  ProgressBar progress("eval", static_cast<int64_t>(pairs.size()));
  for (const auto& pair : pairs) {
    EvalEntry entry;
    entry.name = pair.name;
    entry.sources = {{"pred", pair.pred.empty() ? json(nullptr) : json(pair.pred)},
                     {"gt", pair.gt.empty() ? json(nullptr) : json(pair.gt)}};
    if (!inputs.mask_dir.empty())
      entry.sources["mask"] = pair.mask.empty() ? json(nullptr) : json(pair.mask);
    const std::string regions_path =
        legend.empty() ? "" : region_mask_path(inputs.regions_dir, pair.name + ".png");
    if (!legend.empty()) entry.sources["regions"] = regions_path;
    try {
      require(!pair.pred.empty(), "no prediction in " + inputs.pred_dir);
      require(!pair.gt.empty(), "no ground truth in " + inputs.gt_dir);
      require(inputs.mask_dir.empty() || !pair.mask.empty(), "no mask in " + inputs.mask_dir);
      bool gt_grey = false, pred_grey = false;
      const auto gt = load_rgb_image(pair.gt, resolved.background, &gt_grey);
      entry.width = gt.size(1);
      entry.height = gt.size(0);
      const auto pred = load_rgb_image(pair.pred, resolved.background, &pred_grey);
      // A grey image scored against a colour one would count the missing colour as error.
      if (gt_grey != pred_grey)
        throw Error(std::string(pred_grey ? "the prediction is grey and the ground truth colour"
                                          : "the prediction is colour and the ground truth grey") +
                    " (" + pair.pred + ", " + pair.gt + "): convert one so both match");
      const auto mask = pair.mask.empty() ? torch::Tensor() : load_mask_image(pair.mask);
      const auto regions = legend.empty() ? torch::Tensor()
                                          : region_planes(load_region_mask(regions_path, entry.width,
                                                                           entry.height),
                                                          legend);
      entry.scores = scorer.score(pred, gt, mask, regions);
      entry.ok = true;
    } catch (const c10::Error& e) {
      entry.error = e.what_without_backtrace();
    } catch (const std::exception& e) {
      entry.error = e.what();
    }
    if (!entry.ok) spdlog::warn("{}: {}", entry.name, entry.error);
    report.entries.push_back(std::move(entry));
    progress.update(static_cast<int64_t>(report.entries.size()));
  }
  progress.finish();
  return report;
}

}  // namespace handscs
