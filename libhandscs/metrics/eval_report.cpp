#include "metrics/eval_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "core/atomic_file.h"
#include "core/csv_table.h"
#include "metrics/psnr.h"

namespace handscs {

namespace {

using nlohmann::json;

// Non-finite numbers as text (JSON has none): "inf" (the PSNR of an exact match), "-inf", "nan".
std::string non_finite_text(double x) { return std::isnan(x) ? "nan" : (x > 0 ? "inf" : "-inf"); }

json number(double x) { return std::isfinite(x) ? json(x) : json(non_finite_text(x)); }

json optional_number(const std::optional<double>& x) { return x ? number(*x) : json(nullptr); }

std::string format(const char* pattern, double x) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), pattern, x);
  return buffer;
}

std::string csv_number(const std::optional<double>& x) {
  if (!x) return "";
  if (!std::isfinite(*x)) return non_finite_text(*x);
  return format("%.10g", *x);
}

std::string pad_right(const std::string& text, size_t width) {
  return text.size() >= width ? text : text + std::string(width - text.size(), ' ');
}

std::string pad_left(const std::string& text, size_t width) {
  return text.size() >= width ? text : std::string(width - text.size(), ' ') + text;
}

RegionSummary summarize_region(const EvalReport& report, size_t r) {
  RegionSummary s;
  s.name = report.regions.at(r).name;
  std::vector<double> mse;
  double fraction_sum = 0, ssim_sum = 0, lpips_sum = 0;
  int64_t scored = 0, lpips_count = 0;
  for (const auto& entry : report.entries) {
    if (!entry.ok) continue;
    ++scored;
    const RegionScores& region = entry.scores.regions.at(r);
    fraction_sum += region.fraction;
    if (!region.mse) continue;  // empty here: not part of the region's means
    ++s.images;
    mse.push_back(*region.mse);
    if (region.ssim) {
      ssim_sum += *region.ssim;
      ++s.ssim_images;
    }
    if (region.lpips) {
      lpips_sum += *region.lpips;
      ++lpips_count;
    }
  }
  if (scored > 0) s.pixel_fraction = fraction_sum / scored;
  if (s.images > 0) {
    const PsnrSummary psnr = summarize_psnr(mse);
    s.psnr = psnr.mean_psnr;
    s.psnr_pooled = psnr.pooled_psnr;
    s.mse = psnr.pooled_mse;
    if (lpips_count == s.images) s.lpips = lpips_sum / s.images;
  }
  if (s.ssim_images > 0) s.ssim = ssim_sum / s.ssim_images;
  return s;
}

}  // namespace

EvalSummary EvalReport::summary() const {
  EvalSummary s;
  std::vector<double> mse;
  double ssim_sum = 0, lpips_sum = 0;
  int64_t lpips_count = 0;
  for (const auto& entry : entries) {
    ++s.num_entries;
    if (!entry.ok) {
      ++s.num_failed;
      continue;
    }
    ++s.num_scored;
    mse.push_back(entry.scores.mse);
    ssim_sum += entry.scores.ssim;
    if (entry.scores.lpips) {
      lpips_sum += *entry.scores.lpips;
      ++lpips_count;
    }
  }
  if (s.num_scored > 0) {
    const PsnrSummary psnr = summarize_psnr(mse);
    s.psnr = psnr.mean_psnr;
    s.psnr_pooled = psnr.pooled_psnr;
    s.mse = psnr.pooled_mse;
    s.ssim = ssim_sum / s.num_scored;
    // LPIPS is all or nothing per run; a partial mean would silently cover fewer images.
    if (lpips_count == s.num_scored) s.lpips = lpips_sum / s.num_scored;
  }
  for (size_t r = 0; r < regions.size(); ++r) s.regions.push_back(summarize_region(*this, r));
  return s;
}

json eval_report_to_json(const EvalReport& report) {
  const EvalSummary s = report.summary();
  json out;
  out["mode"] = report.mode;
  out["inputs"] = report.inputs;
  out["config"] = report.config;
  out["lpips"] = {{"enabled", report.lpips_skip_reason.empty()},
                  {"skipped_reason", report.lpips_skip_reason.empty()
                                         ? json(nullptr)
                                         : json(report.lpips_skip_reason)}};
  out["summary"] = {{"images", s.num_entries},   {"scored", s.num_scored},
                    {"failed", s.num_failed},    {"psnr", optional_number(s.psnr)},
                    {"psnr_pooled_mse", optional_number(s.psnr_pooled)},
                    {"mse", optional_number(s.mse)}, {"ssim", optional_number(s.ssim)},
                    {"lpips", optional_number(s.lpips)}};
  if (!report.regions.empty()) {
    json regions = json::object();
    for (size_t r = 0; r < report.regions.size(); ++r) {
      const RegionSpec& spec = report.regions[r];
      const RegionSummary& region = s.regions[r];
      regions[spec.name] = {{"bit", spec.bit},
                            {"description", spec.description},
                            {"images", region.images},
                            {"ssim_images", region.ssim_images},
                            {"pixel_fraction", region.pixel_fraction},
                            {"psnr", optional_number(region.psnr)},
                            {"psnr_pooled_mse", optional_number(region.psnr_pooled)},
                            {"mse", optional_number(region.mse)},
                            {"ssim", optional_number(region.ssim)},
                            {"lpips", optional_number(region.lpips)}};
    }
    out["regions"] = regions;
  }
  json images = json::array();
  json failed = json::array();
  for (const auto& entry : report.entries) {
    json item = {{"name", entry.name}, {"sources", entry.sources}};
    if (entry.width > 0) {
      item["width"] = entry.width;
      item["height"] = entry.height;
    }
    if (entry.ok) {
      item["psnr"] = number(entry.scores.psnr);
      item["ssim"] = number(entry.scores.ssim);
      item["lpips"] = optional_number(entry.scores.lpips);
      item["mse"] = number(entry.scores.mse);
      if (!report.regions.empty()) {
        json regions = json::object();
        for (size_t r = 0; r < report.regions.size(); ++r) {
          const RegionScores& region = entry.scores.regions.at(r);
          regions[report.regions[r].name] = {
              {"pixels", region.pixels},           {"fraction", region.fraction},
              {"psnr", optional_number(region.psnr)}, {"ssim", optional_number(region.ssim)},
              {"lpips", optional_number(region.lpips)}, {"mse", optional_number(region.mse)}};
        }
        item["regions"] = regions;
      }
      images.push_back(item);
    } else {
      item["error"] = entry.error;
      failed.push_back(item);
    }
  }
  out["images"] = images;
  out["failed"] = failed;
  return out;
}

std::string eval_report_to_csv(const EvalReport& report) {
  std::string text = "name,status,psnr,ssim,lpips,mse,";
  for (const auto& region : report.regions)
    for (const char* column : {"_psnr", "_ssim", "_lpips", "_fraction"})
      text += csv_cell(region.name + column) + ",";
  text += "width,height,error\n";
  for (const auto& entry : report.entries) {
    const bool ok = entry.ok;
    text += csv_cell(entry.name) + "," + (ok ? "ok" : "failed") + ",";
    text += (ok ? csv_number(entry.scores.psnr) : "") + ",";
    text += (ok ? csv_number(entry.scores.ssim) : "") + ",";
    text += (ok ? csv_number(entry.scores.lpips) : "") + ",";
    text += (ok ? csv_number(entry.scores.mse) : "") + ",";
    for (size_t r = 0; r < report.regions.size(); ++r) {
      if (!ok) {
        text += ",,,,";
        continue;
      }
      const RegionScores& region = entry.scores.regions.at(r);
      text += csv_number(region.psnr) + "," + csv_number(region.ssim) + "," +
              csv_number(region.lpips) + "," + csv_number(region.fraction) + ",";
    }
    text += (entry.width > 0 ? std::to_string(entry.width) : "") + ",";
    text += (entry.height > 0 ? std::to_string(entry.height) : "") + ",";
    text += csv_cell(entry.error) + "\n";
  }
  return text;
}

std::string format_eval_table(const EvalReport& report) {
  const EvalSummary s = report.summary();
  size_t name_width = 10;
  for (const auto& entry : report.entries) name_width = std::max(name_width, entry.name.size() + 2);
  std::string text = pad_right("image", name_width) + pad_left("PSNR", 9) + pad_left("SSIM", 9) +
                     pad_left("LPIPS", 9) + "\n";
  for (const auto& entry : report.entries) {
    if (!entry.ok) continue;
    text += pad_right(entry.name, name_width) + pad_left(score_text(entry.scores.psnr, 3), 9) +
            pad_left(score_text(entry.scores.ssim, 5), 9) +
            pad_left(score_text(entry.scores.lpips, 5), 9) + "\n";
  }
  text += pad_right("mean (" + std::to_string(s.num_scored) + ")", name_width) +
          pad_left(score_text(s.psnr, 3), 9) + pad_left(score_text(s.ssim, 5), 9) +
          pad_left(score_text(s.lpips, 5), 9) + "\n";
  text += "PSNR of the pooled MSE: " + score_text(s.psnr_pooled, 3) + " dB\n";
  if (!s.regions.empty()) {
    size_t region_width = 8;
    for (const auto& region : s.regions) region_width = std::max(region_width, region.name.size() + 2);
    text += "\nregions (over the images where the region has pixels: PSNR of their pooled MSE, SSIM and "
            "LPIPS means):\n";
    text += pad_right("region", region_width) + pad_left("images", 10) + pad_left("area", 9) +
            pad_left("PSNR", 9) + pad_left("SSIM", 9) + pad_left("LPIPS", 9) + "\n";
    for (const auto& region : s.regions)
      text += pad_right(region.name, region_width) +
              pad_left(std::to_string(region.images) + "/" + std::to_string(s.num_scored), 10) +
              pad_left(format("%.2f%%", 100 * region.pixel_fraction), 9) +
              pad_left(score_text(region.psnr_pooled, 3), 9) +
              pad_left(score_text(region.ssim, 5), 9) +
              pad_left(score_text(region.lpips, 5), 9) + "\n";
  }
  const auto& config = report.config;
  if (config.contains("ssim") && config.contains("lpips"))
    text += "SSIM " + config["ssim"].value("variant", std::string("?")) + ", LPIPS " +
            config["lpips"].value("net", std::string("?")) + " v0.1 (" +
            config["lpips"].value("input_range", std::string("?")) + ")\n";
  if (!report.lpips_skip_reason.empty())
    text += "LPIPS skipped (reported as null): " + report.lpips_skip_reason + "\n";
  if (s.num_failed > 0) {
    text += std::to_string(s.num_failed) + " of " + std::to_string(s.num_entries) +
            " images failed and are excluded from the means:\n";
    for (const auto& entry : report.entries)
      if (!entry.ok) text += "  " + entry.name + ": " + entry.error + "\n";
  }
  return text;
}

void write_eval_outputs(const EvalReport& report, const std::string& json_path,
                        const std::string& csv_path) {
  auto write = [](const std::string& path, const std::string& bytes) {
    const auto parent = std::filesystem::path(path).parent_path();
    if (!parent.empty()) ensure_directory(parent.string());
    write_file_atomic(path, bytes);
  };
  if (!json_path.empty()) write(json_path, eval_report_to_json(report).dump(2) + "\n");
  if (!csv_path.empty()) write(csv_path, eval_report_to_csv(report));
}

std::string score_text(const std::optional<double>& score, int digits) {
  if (!score) return "n/a";
  if (!std::isfinite(*score)) return non_finite_text(*score);
  return format(("%." + std::to_string(digits) + "f").c_str(), *score);
}

}  // namespace handscs
