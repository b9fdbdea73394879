#include "sweep/results_table.h"

#include <spdlog/spdlog.h>

#include "core/error.h"
#include "core/text.h"

namespace handscs {

const std::vector<std::string>& result_columns() {
  static const std::vector<std::string> columns = {
      "point",     "budget",      "threads",  "settings",     "status",      "train_wall_s",
      "loop_s",    "ms_per_step", "peak_rss_mb", "gaussians", "skipped_steps", "rollbacks",
      "eval_images", "psnr",      "ssim",     "lpips",        "eval_wall_s", "render_fps",
      "data_ms",   "forward_ms",  "losses_ms", "backward_ms", "optimizer_ms", "resumed_from_step"};
  return columns;
}

CsvTable read_results(const std::string& path) {
  const auto& columns = result_columns();
  CsvTable table = read_csv(path);
  if (table.header == columns) return table;
  // The layout before a stopped run could be continued: every column but the last.
  const std::vector<std::string> before_resume(columns.begin(), columns.end() - 1);
  if (table.header != before_resume)
    throw Error(path + ": not a results.csv of this version or the one before; its columns "
                "differ from " + join(columns, ","));
  spdlog::info("{}: written before the column {} existed; it is read empty in its rows", path,
               columns.back());
  for (auto& row : table.rows) row.resize(columns.size());
  table.header = columns;
  return table;
}

}  // namespace handscs
