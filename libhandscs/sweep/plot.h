// Line/scatter charts drawn with OpenCV alone, for sweep reports: axes with "nice" ticks, optional log10
// axes, grid, legend. Data maps to pixels by px = left + (t(x) - t(lo)) / (t(hi) - t(lo)) * (width - 1),
// with t = log10 on a log axis and the identity otherwise (y the same, upwards).
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace handscs {

struct PlotSeries {
  std::string label;            // legend text ("" keeps the series out of the legend)
  std::vector<double> x, y;     // same length; non-finite points are skipped (not drawn), never crash
  bool lines = true;            // connect points in the given order (broken at skipped points)
  bool markers = true;          // draw a small circle at each point
  bool dashed = false;          // dashed line (used for the Pareto front)
  std::optional<cv::Scalar> color;  // explicit BGR colour; default: plot_color(series index)
};

struct PlotSpec {
  std::string title, x_label, y_label;
  bool log_x = false, log_y = false;   // log10 axes (non-positive values skipped on a log axis)
  int width = 960, height = 640;       // pixels
};

// One axis as draw_plot lays it out.
struct PlotAxis {
  double lo = 0, hi = 1;          // shown range in data units, lo < hi (both > 0 on a log axis)
  bool log = false;               // log10 axis
  std::vector<double> ticks;      // tick values in data units, increasing, inside [lo, hi]
};

// Where draw_plot puts things.
struct PlotLayout {
  cv::Rect area;                  // the axes box in pixels; lo/hi map to its first/last pixel centres
  PlotAxis x, y;
  cv::Rect legend;                // the legend box (empty when no series has a label)
};

// Axis for these data values: range of the finite values (positive ones on a log axis) plus a 5% margin
// on each side, ticks at 1, 2, 5 x 10^k (4 to 8 of them; the range grows to the next tick when no step
// fits) or, on a log axis, at decades (every n-th past 8; 1-2-5 values when under 3 decades fit).
// No values gives [0, 1] ([1, 10] on a log axis); a zero range is widened by 10% (half a decade).
PlotAxis make_plot_axis(const std::vector<double>& values, bool log);

// Tick labels as drawn: the shortest text that reads back as the tick (to 1e-6 of the tick spacing, or of
// the tick on a log axis), fixed-point for magnitudes in [1e-4, 1e6), else "2.5e-5" style ("0" for zero). Linear ticks
// share one number of decimals ("2.5 3.0 3.5"); log ticks are shortened one by one ("0.5 1 2 5").
std::vector<std::string> plot_tick_labels(const PlotAxis& axis);

// The layout draw_plot uses for these series and spec. Throws Error for a size under 160 x 120 pixels
// or a series whose x and y differ in length.
PlotLayout plot_layout(const std::vector<PlotSeries>& series, const PlotSpec& spec);

// Colour of series `index` (BGR): the Okabe-Ito colour-blind-safe palette, then four darker colours,
// repeating after 12 series (the full sweep has 10 settings).
cv::Scalar plot_color(size_t index);

// Draws the chart: white background, axes with 4-8 "nice" tick values (1, 2, 5 x 10^k; decades on
// log axes) and their labels, axis titles, title, light grid, one distinct colour per series from a
// fixed colour-blind-safe palette (e.g. Okabe-Ito), legend box in a corner. Axis ranges come from the
// finite data with a small margin; a single point or zero range still gives a valid axis.
cv::Mat draw_plot(const std::vector<PlotSeries>& series, const PlotSpec& spec);  // CV_8UC3 BGR

// The same, written as PNG atomically (temp file + rename); throws handscs::Error naming the path on failure.
void write_plot_png(const std::string& path, const std::vector<PlotSeries>& series, const PlotSpec& spec);

// Pixel position of data point (x, y) in a chart drawn by draw_plot with these series and spec (for tests
// and annotations): same mapping as the drawing uses. NaN coordinates for a point draw_plot would skip.
cv::Point2d plot_to_pixel(const std::vector<PlotSeries>& series, const PlotSpec& spec, double x, double y);

// The same mapping for a layout already computed (cheaper when placing many annotations).
cv::Point2d plot_to_pixel(const PlotLayout& layout, double x, double y);

}  // namespace handscs
