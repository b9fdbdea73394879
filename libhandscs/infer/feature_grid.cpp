#include "infer/feature_grid.h"

#include <algorithm>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace handscs {

namespace {

// Text and spacing in pixels: a 0.5-scale Hershey line is ~12 px tall, so lines are 18 px apart.
constexpr double kFontScale = 0.5;
constexpr int kLineHeight = 18;
constexpr int kPad = 6;  // space around text and between cells
const cv::Scalar kText(255, 255, 255);
const cv::Scalar kGap(64, 64, 64);

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

int text_width(const std::string& text) {
  int baseline = 0;
  return cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, kFontScale, 1, &baseline).width;
}

void put_line(cv::Mat& image, const std::string& text, int x, int baseline_y) {
  cv::putText(image, text, {x, baseline_y}, cv::FONT_HERSHEY_SIMPLEX, kFontScale, kText, 1, cv::LINE_AA);
}

}  // namespace

cv::Mat compose_grid(const LabelledGrid& grid) {
  const size_t rows = grid.cells.size();
  require(rows > 0 && !grid.cells[0].empty(), "compose_grid: no cells");
  const size_t cols = grid.cells[0].size();
  require(grid.row_labels.size() == rows && grid.column_labels.size() == cols,
          "compose_grid: " + std::to_string(rows) + "x" + std::to_string(cols) + " cells need as many row and "
          "column labels, got " + std::to_string(grid.row_labels.size()) + " and " +
          std::to_string(grid.column_labels.size()));
  const cv::Size cell = grid.cells[0][0].size();
  for (const auto& row : grid.cells) {
    require(row.size() == cols, "compose_grid: rows of different lengths");
    for (const auto& c : row)
      require(c.size() == cell && c.type() == CV_8UC3, "compose_grid: cells must be 8-bit BGR of one size");
  }
  int label_width = 0;
  int header_lines = std::max<int>(1, static_cast<int>(lines_of(grid.corner).size()));
  for (const auto& label : grid.row_labels)
    for (const auto& line : lines_of(label)) label_width = std::max(label_width, text_width(line));
  for (const auto& line : lines_of(grid.corner)) label_width = std::max(label_width, text_width(line));
  for (const auto& label : grid.column_labels)
    header_lines = std::max<int>(header_lines, static_cast<int>(lines_of(label).size()));
  const int left = label_width + 2 * kPad;
  const int top = header_lines * kLineHeight + 2 * kPad;
  const int width = left + static_cast<int>(cols) * (cell.width + kPad);
  const int height = top + static_cast<int>(rows) * (cell.height + kPad);
  cv::Mat out(height, width, CV_8UC3, kGap);
  out(cv::Rect(0, 0, width, top)).setTo(cv::Scalar(0, 0, 0));
  out(cv::Rect(0, 0, left, height)).setTo(cv::Scalar(0, 0, 0));
  const auto corner = lines_of(grid.corner);
  for (size_t k = 0; k < corner.size(); ++k)
    put_line(out, corner[k], kPad, kPad + static_cast<int>(k + 1) * kLineHeight - 4);
  for (size_t c = 0; c < cols; ++c) {
    const int x0 = left + static_cast<int>(c) * (cell.width + kPad);
    const auto lines = lines_of(grid.column_labels[c]);
    for (size_t k = 0; k < lines.size(); ++k)
      put_line(out, lines[k], x0 + std::max(0, (cell.width - text_width(lines[k])) / 2),
               kPad + static_cast<int>(k + 1) * kLineHeight - 4);
  }
  for (size_t r = 0; r < rows; ++r) {
    const int y0 = top + static_cast<int>(r) * (cell.height + kPad);
    const auto lines = lines_of(grid.row_labels[r]);
    const int text_top = y0 + std::max(0, (cell.height - static_cast<int>(lines.size()) * kLineHeight) / 2);
    for (size_t k = 0; k < lines.size(); ++k)
      put_line(out, lines[k], kPad, text_top + static_cast<int>(k + 1) * kLineHeight - 4);
    for (size_t c = 0; c < cols; ++c)
      grid.cells[r][c].copyTo(out(cv::Rect(left + static_cast<int>(c) * (cell.width + kPad), y0, cell.width,
                                           cell.height)));
  }
  return out;
}

PixelRect coverage_box(const std::vector<torch::Tensor>& alphas, int margin) {
  require(!alphas.empty(), "coverage_box: no images");
  const int64_t h = alphas[0].size(0), w = alphas[0].size(1);
  torch::Tensor covered = torch::zeros({h, w}, torch::kBool);
  for (const auto& a : alphas) {
    TORCH_CHECK(a.dim() == 2 && a.size(0) == h && a.size(1) == w, "coverage_box: alphas must all be [", h,
                ", ", w, "], got ", a.sizes());
    covered |= a > 1.0 / 255;  // what an 8-bit image shows at all
  }
  const int W = static_cast<int>(w), H = static_cast<int>(h);
  if (!covered.any().item<bool>()) return {0, 0, W, H};
  const auto cols = torch::nonzero(covered.any(0)).flatten();
  const auto rows = torch::nonzero(covered.any(1)).flatten();
  PixelRect r;
  r.x0 = std::max(0, static_cast<int>(cols.min().item<int64_t>()) - margin);
  r.x1 = std::min(W, static_cast<int>(cols.max().item<int64_t>()) + 1 + margin);
  r.y0 = std::max(0, static_cast<int>(rows.min().item<int64_t>()) - margin);
  r.y1 = std::min(H, static_cast<int>(rows.max().item<int64_t>()) + 1 + margin);
  return r;
}

}  // namespace handscs
