#include "metrics/comparison_panel.h"

#include <algorithm>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "metrics/image_tensor.h"

namespace handscs {

namespace {

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
// Text scales with the image: the simplex font's capitals are ~22 px tall at scale 1; a 334-px-wide
// column gets scale 0.45 (about 10 px), readable at the image's own size.
double font_scale(int width) { return std::clamp(width / 740.0, 0.3, 1.5); }

// One header line: the font's height above the baseline, its descent below, and a margin.
struct LineMetrics {
  int ascent = 0, descent = 0, pad = 0;
  int height() const { return ascent + descent + 2 * pad; }
};

LineMetrics line_metrics(int width) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize("Agjp|", kFont, font_scale(width), 1, &baseline);
  LineMetrics m;
  m.ascent = size.height;
  m.descent = baseline + 1;  // +1: anti-aliasing reaches one pixel further
  m.pad = std::max(2, size.height / 4);
  return m;
}

// Writes `text` in the header line whose top row is `top`, from column x.
void put_line(cv::Mat& image, const std::string& text, int x, int top, int width) {
  const LineMetrics m = line_metrics(width);
  cv::putText(image, text, {x, top + m.pad + m.ascent}, kFont, font_scale(width),
              cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
}

}  // namespace

int comparison_panel_header_height(int width) { return 2 * line_metrics(width).height(); }

cv::Mat comparison_panel(const torch::Tensor& pred, const torch::Tensor& gt,
                         const std::string& caption) {
  require(pred.dim() == 3 && pred.size(2) == 3 && pred.sizes() == gt.sizes(),
          "comparison_panel: pred and gt must both be [H, W, 3]");
  const auto p = pred.to(torch::kFloat32).clamp(0, 1);
  const auto g = gt.to(torch::kFloat32).clamp(0, 1);
  const auto err = (p - g).abs().mean(2).mul(kPanelErrorGain).clamp(0, 1).mul(255).round()
                       .to(torch::kUInt8).contiguous();
  const int h = static_cast<int>(p.size(0)), w = static_cast<int>(p.size(1));
  cv::Mat err8(h, w, CV_8UC1, err.data_ptr<uint8_t>());
  cv::Mat heat;
  cv::applyColorMap(err8, heat, cv::COLORMAP_JET);
  cv::Mat columns;
  cv::hconcat(std::vector<cv::Mat>{rgb_tensor_to_mat(p), rgb_tensor_to_mat(g), heat}, columns);

  const LineMetrics m = line_metrics(w);
  const int line = m.height();
  cv::Mat panel(h + 2 * line, 3 * w, CV_8UC3, cv::Scalar(40, 40, 40));
  columns.copyTo(panel(cv::Rect(0, 2 * line, 3 * w, h)));
  // The caption over the whole width, then each column's title over its column (clipped to it).
  put_line(panel, caption, m.pad, 0, w);
  const char* titles[] = {"render", "ground truth", "|error| x4"};
  for (int c = 0; c < 3; ++c) {
    cv::Mat column = panel(cv::Rect(c * w, line, w, line));
    put_line(column, titles[c], m.pad, 0, w);
  }
  return panel;
}

}  // namespace handscs
