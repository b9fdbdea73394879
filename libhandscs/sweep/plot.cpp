#include "sweep/plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <limits>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/atomic_file.h"
#include "core/error.h"

namespace handscs {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr int kShift = 4;  // sub-pixel bits for cv::line/cv::circle: positions to 1/16 pixel

const cv::Scalar kBackground(255, 255, 255);
const cv::Scalar kGrid(228, 228, 228);
const cv::Scalar kAxis(70, 70, 70);
const cv::Scalar kText(30, 30, 30);
const cv::Scalar kLegendBorder(170, 170, 170);

// Sizes scale with the image area so charts of any size look alike; 960 x 640 is scale 1. The floor
// keeps Hershey text legible on small charts (below ~0.35 its strokes merge).
struct Style {
  double ui = 1;
  double tick_font = 0.5, label_font = 0.6, title_font = 0.75, legend_font = 0.5;
  int thickness = 1, title_thickness = 2;
  int pad = 12, tick_len = 5, line_thickness = 2, marker_radius = 4;
  double dash = 10, gap = 6;
};

Style style_for(const PlotSpec& spec) {
  Style s;
  s.ui = std::clamp(std::sqrt(double(spec.width) * spec.height / (960.0 * 640.0)), 0.7, 3.0);
  s.tick_font *= s.ui;
  s.label_font *= s.ui;
  s.title_font *= s.ui;
  s.legend_font *= s.ui;
  s.thickness = std::max(1, int(std::lround(s.ui)));
  s.title_thickness = std::max(1, int(std::lround(2 * s.ui)));
  s.pad = int(std::lround(12 * s.ui));
  s.tick_len = int(std::lround(5 * s.ui));
  s.line_thickness = std::max(1, int(std::lround(2 * s.ui)));
  s.marker_radius = std::max(2, int(std::lround(4 * s.ui)));
  s.dash = 10 * s.ui;
  s.gap = 6 * s.ui;
  return s;
}

bool drawable(double v, bool log) { return std::isfinite(v) && (!log || v > 0); }
double to_axis(double v, bool log) { return log ? std::log10(v) : v; }

// m x 10^e, divided rather than multiplied for e < 0 so 3 x 0.1 comes out as the double nearest 0.3.
double scaled(double m, int e) { return e >= 0 ? m * std::pow(10.0, e) : m / std::pow(10.0, -e); }

// The multiples of m x 10^e inside [lo, hi], each computed as scaled(i m, e) so a tick and a range end
// that should coincide are the same double. Looks one index past each end: lo / step may round either way.
std::vector<double> multiples(double lo, double hi, double m, int e) {
  const double step = scaled(m, e);
  std::vector<double> ticks;
  // Indices past 1e15 would stall ++i (doubles are spaced 1 apart near 2^53); such a step is unusable.
  if (!(std::abs(lo / step) < 1e15 && std::abs(hi / step) < 1e15)) return ticks;
  for (double i = std::ceil(lo / step) - 1; i <= std::floor(hi / step) + 1; ++i) {
    const double t = scaled(i * m, e);
    if (t >= lo && t <= hi) ticks.push_back(t);
  }
  return ticks;
}

// Multiples of a 1-2-5 step inside [lo, hi]: 4 to 8 of them, the count closest to 6 (larger step on a
// tie). The step sequence more than halves the count from 2 to 5, so some ranges get 9+ or 3 and no
// count between; then the 3-tick step is taken (never fewer: the step before it gave 9+ and it is at most
// 2.5 times larger) and the range grows to the nearer next multiple.
std::vector<double> linear_ticks(double& lo, double& hi) {
  const double range = hi - lo;
  if (!(range > 0) || !std::isfinite(range)) return {};
  const int e0 = int(std::floor(std::log10(range)));
  std::vector<double> best, fallback;
  double fallback_m = 0;
  int fallback_e = 0;
  for (int e = e0 - 2; e <= e0 + 1; ++e) {
    for (double m : {1.0, 2.0, 5.0}) {
      auto ticks = multiples(lo, hi, m, e);
      const double count = double(ticks.size());
      if (count >= 4 && count <= 8) {
        if (best.empty() || std::abs(count - 6) <= std::abs(double(best.size()) - 6)) best = std::move(ticks);
      } else if (count < 4 && fallback_m == 0) {
        fallback = std::move(ticks);
        fallback_m = m;
        fallback_e = e;
      }
    }
  }
  if (!best.empty() || fallback.empty()) return best;
  const double step = scaled(fallback_m, fallback_e);
  const double below = scaled((std::round(fallback.front() / step) - 1) * fallback_m, fallback_e);
  const double above = scaled((std::round(fallback.back() / step) + 1) * fallback_m, fallback_e);
  if (lo - below <= above - hi) {
    lo = below;
    fallback.insert(fallback.begin(), below);
  } else {
    hi = above;
    fallback.push_back(above);
  }
  return fallback;
}

// Log-axis ticks in data units (0 < lo < hi): decades, every n-th when more than 8; with fewer than 3
// decades inside, the 1-2-5 values; with fewer than 3 of those (range under ~2.5x), linear ticks.
std::vector<double> log_ticks(double& lo, double& hi) {
  const double tl = std::log10(lo), th = std::log10(hi);
  const int d0 = int(std::ceil(tl)), d1 = int(std::floor(th));
  std::vector<double> ticks;
  if (d1 - d0 + 1 >= 3) {
    const int stride = (d1 - d0 + 1 + 7) / 8;
    for (int k = d0; k <= d1; ++k)
      if (((k % stride) + stride) % stride == 0) ticks.push_back(scaled(1, k));
    return ticks;
  }
  for (int k = int(std::floor(tl)); k <= d1; ++k)
    for (double m : {1.0, 2.0, 5.0}) {
      const double t = scaled(m, k);
      if (t >= lo && t <= hi) ticks.push_back(t);
    }
  if (ticks.size() >= 3) return ticks;
  return linear_ticks(lo, hi);
}

// "1e+06" -> "1e6", "2.5e-05" -> "2.5e-5".
std::string tidy_exponent(std::string s) {
  const size_t e = s.find('e');
  if (e == std::string::npos) return s;
  std::string mantissa = s.substr(0, e), exponent = s.substr(e + 1);
  std::string sign;
  if (!exponent.empty() && (exponent[0] == '+' || exponent[0] == '-')) {
    if (exponent[0] == '-') sign = "-";
    exponent = exponent.substr(1);
  }
  exponent.erase(0, std::min(exponent.find_first_not_of('0'), exponent.size() - 1));
  return mantissa + "e" + sign + exponent;
}

// Width and full height (ascent + descent) of a text line.
cv::Size text_extent(const std::string& text, double scale, int thickness) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text.empty() ? " " : text, kFont, scale, thickness, &baseline);
  return {text.empty() ? 0 : size.width, size.height + baseline};
}

int text_ascent(double scale, int thickness) {
  int baseline = 0;
  return cv::getTextSize("0Ag", kFont, scale, thickness, &baseline).height;
}

// A font scale no larger than `scale` at which `text` fits in `max_width` pixels.
double fit_scale(const std::string& text, double scale, int thickness, int max_width) {
  const int width = text_extent(text, scale, thickness).width;
  return (width > max_width && width > 0) ? scale * double(max_width) / width : scale;
}

void validate(const std::vector<PlotSeries>& series, const PlotSpec& spec) {
  // Below 160 x 120 the margins leave no plot; above 16384 a chart is surely a unit mix-up.
  require(spec.width >= 160 && spec.height >= 120 && spec.width <= 16384 && spec.height <= 16384,
          "plot: size " + std::to_string(spec.width) + " x " + std::to_string(spec.height) +
              " is outside 160 x 120 .. 16384 x 16384 pixels");
  for (const auto& s : series)
    require(s.x.size() == s.y.size(), "plot: series '" + s.label + "': x has " + std::to_string(s.x.size()) +
                                          " values, y has " + std::to_string(s.y.size()));
}

// Calls visit(run) for each maximal run of consecutive drawable points of `s`, in pixels.
void for_each_run(const PlotLayout& layout, const PlotSeries& s,
                  const std::function<void(const std::vector<cv::Point2d>&)>& visit) {
  std::vector<cv::Point2d> run;
  for (size_t i = 0; i <= s.x.size(); ++i) {
    const cv::Point2d p = i < s.x.size() ? plot_to_pixel(layout, s.x[i], s.y[i]) : cv::Point2d(kNaN, kNaN);
    if (std::isfinite(p.x) && std::isfinite(p.y)) {
      run.push_back(p);
    } else if (!run.empty()) {
      visit(run);
      run.clear();
    }
  }
}

struct LegendEntry {
  size_t index;
  const PlotSeries* series;
};

std::vector<LegendEntry> legend_entries(const std::vector<PlotSeries>& series) {
  std::vector<LegendEntry> entries;
  for (size_t i = 0; i < series.size(); ++i)
    if (!series[i].label.empty()) entries.push_back({i, &series[i]});
  return entries;
}

int legend_row_height(const Style& st) { return text_extent("0Ag", st.legend_font, st.thickness).height + st.pad / 2; }
int legend_sample_width(const Style& st) { return int(std::lround(36 * st.ui)); }

// The legend goes in the corner of the plot area that covers the fewest markers and line samples
// (top-right, top-left, bottom-right, bottom-left on a tie).
cv::Rect place_legend(const PlotLayout& layout, const std::vector<PlotSeries>& series, const Style& st) {
  const auto entries = legend_entries(series);
  if (entries.empty()) return {};
  int text_width = 0;
  for (const auto& e : entries) text_width = std::max(text_width, text_extent(e.series->label, st.legend_font, st.thickness).width);
  const int width = st.pad + legend_sample_width(st) + st.pad / 2 + text_width + st.pad;
  const int height = st.pad / 2 + int(entries.size()) * legend_row_height(st) + st.pad / 2;
  const cv::Rect& a = layout.area;
  const int left = a.x + st.pad, right = a.x + a.width - st.pad - width;
  const int top = a.y + st.pad, bottom = a.y + a.height - st.pad - height;
  const cv::Rect corners[4] = {{right, top, width, height}, {left, top, width, height},
                               {right, bottom, width, height}, {left, bottom, width, height}};
  int covered[4] = {0, 0, 0, 0};
  const double reach = st.marker_radius + st.line_thickness;
  auto count = [&](const cv::Point2d& p) {
    for (int c = 0; c < 4; ++c) {
      const cv::Rect& r = corners[c];
      if (p.x >= r.x - reach && p.x <= r.x + r.width + reach && p.y >= r.y - reach && p.y <= r.y + r.height + reach)
        ++covered[c];
    }
  };
  for (const auto& s : series) {
    for_each_run(layout, s, [&](const std::vector<cv::Point2d>& run) {
      for (size_t i = 0; i < run.size(); ++i) {
        count(run[i]);
        if (!s.lines || i + 1 == run.size()) continue;
        // Up to 16 samples per segment, one every ~4 pixels: enough to see a line crossing the box.
        const int n = int(std::min(16.0, std::ceil(cv::norm(run[i + 1] - run[i]) / 4)));
        for (int k = 1; k < n; ++k) count(run[i] + (run[i + 1] - run[i]) * (double(k) / n));
      }
    });
  }
  const int best = int(std::min_element(covered, covered + 4) - covered);
  return corners[best];
}

cv::Point fixed_point(const cv::Point2d& p) {
  return {int(std::lround(p.x * (1 << kShift))), int(std::lround(p.y * (1 << kShift)))};
}

void draw_segment(cv::Mat& image, const cv::Point2d& a, const cv::Point2d& b, const cv::Scalar& color, int thickness) {
  cv::line(image, fixed_point(a), fixed_point(b), color, thickness, cv::LINE_AA, kShift);
}

void draw_marker(cv::Mat& image, const cv::Point2d& c, const cv::Scalar& color, int radius) {
  cv::circle(image, fixed_point(c), radius << kShift, color, cv::FILLED, cv::LINE_AA, kShift);
}

// A polyline, solid or dashed; the dash pattern runs on across vertices.
void draw_polyline(cv::Mat& image, const std::vector<cv::Point2d>& run, const cv::Scalar& color, const Style& st,
                   bool dashed) {
  double phase = 0;  // distance into the current dash + gap period
  for (size_t i = 0; i + 1 < run.size(); ++i) {
    const cv::Point2d a = run[i], d = run[i + 1] - run[i];
    const double length = cv::norm(d);
    if (!dashed) {
      draw_segment(image, a, run[i + 1], color, st.line_thickness);
      continue;
    }
    // Each step ends the segment or lands exactly on the next dash/gap boundary: adding a remainder
    // to the position could round to no progress and loop forever.
    for (double s = 0; s < length;) {
      const bool on = phase < st.dash;
      const double room = (on ? st.dash : st.dash + st.gap) - phase;
      if (length - s <= room) {
        if (on) draw_segment(image, a + d * (s / length), run[i + 1], color, st.line_thickness);
        phase += length - s;
        s = length;
      } else {
        if (on) draw_segment(image, a + d * (s / length), a + d * ((s + room) / length), color, st.line_thickness);
        s += room;
        phase = on ? st.dash : 0;
      }
    }
  }
}

// Text centred on `center`, rotated 90 degrees counter-clockwise (reads bottom to top).
void put_text_vertical(cv::Mat& image, const std::string& text, cv::Point center, double scale, int thickness) {
  const cv::Size size = text_extent(text, scale, thickness);
  cv::Mat patch(size.height, size.width, CV_8UC3, kBackground);
  cv::putText(patch, text, {0, text_ascent(scale, thickness)}, kFont, scale, kText, thickness, cv::LINE_AA);
  cv::Mat rotated;
  cv::rotate(patch, rotated, cv::ROTATE_90_COUNTERCLOCKWISE);
  const cv::Rect target(center.x - rotated.cols / 2, center.y - rotated.rows / 2, rotated.cols, rotated.rows);
  const cv::Rect clipped = target & cv::Rect(0, 0, image.cols, image.rows);
  if (clipped.empty()) return;
  cv::Mat region = image(clipped);
  // Dark text on white: the darker of the two keeps the text and whatever is under its background.
  cv::min(region, rotated(clipped - target.tl()), region);
}

void put_text(cv::Mat& image, const std::string& text, cv::Point baseline_left, double scale, int thickness) {
  cv::putText(image, text, baseline_left, kFont, scale, kText, thickness, cv::LINE_AA);
}

struct Margins {
  int left, right, top, bottom;
};

Margins margins_for(const PlotSpec& spec, const Style& st, const std::vector<std::string>& x_labels,
                    const std::vector<std::string>& y_labels) {
  const int tick_height = text_extent("0", st.tick_font, st.thickness).height;
  const int label_height = text_extent("0Ag", st.label_font, st.thickness).height;
  const int title_height = text_extent("0Ag", st.title_font, st.title_thickness).height;
  int y_label_width = 0;
  for (const auto& l : y_labels) y_label_width = std::max(y_label_width, text_extent(l, st.tick_font, st.thickness).width);
  const int last_x_label = x_labels.empty() ? 0 : text_extent(x_labels.back(), st.tick_font, st.thickness).width;
  Margins m;
  m.top = st.pad + (spec.title.empty() ? st.pad : title_height + st.pad);
  m.left = st.pad + (spec.y_label.empty() ? 0 : label_height + st.pad) + y_label_width + st.pad / 2 + st.tick_len;
  m.bottom = st.tick_len + st.pad / 2 + tick_height + (spec.x_label.empty() ? 0 : st.pad + label_height) + st.pad;
  m.right = std::max(2 * st.pad, last_x_label / 2 + st.pad);
  return m;
}

}  // namespace

PlotAxis make_plot_axis(const std::vector<double>& values, bool log) {
  double lo = kInf, hi = -kInf;  // in axis units (log10 on a log axis)
  double data_lo = kInf, data_hi = -kInf;
  for (double v : values) {
    if (!drawable(v, log)) continue;
    lo = std::min(lo, to_axis(v, log));
    hi = std::max(hi, to_axis(v, log));
    data_lo = std::min(data_lo, v);
    data_hi = std::max(data_hi, v);
  }
  if (lo > hi) {
    lo = 0;
    hi = 1;
  } else if (hi - lo <= 1e-9 * (log ? 1.0 : std::max(std::abs(lo), std::abs(hi)))) {
    // One value, or a spread under 1e-9 of the values (1e-9 decades on a log axis) that ticks could not
    // resolve: half a decade, 10% of the value, or 1 around zero.
    const double mid = 0.5 * (lo + hi);
    const double half = log ? 0.5 : (std::abs(mid) > 1e-300 ? 0.1 * std::abs(mid) : 1.0);
    lo = mid - half;
    hi = mid + half;
  }
  PlotAxis axis;
  axis.log = log;
  auto from_axis = [&](double t) { return log ? std::pow(10.0, t) : t; };
  // 5% of the range on each side keeps markers off the axes box; dropped if it would overflow.
  const double margin = 0.05 * (hi - lo);
  const double lo_m = from_axis(lo - margin), hi_m = from_axis(hi + margin);
  const bool margin_ok = std::isfinite(lo_m) && std::isfinite(hi_m) && (!log || lo_m > 0);
  axis.lo = margin_ok ? lo_m : from_axis(lo);
  axis.hi = margin_ok ? hi_m : from_axis(hi);
  if (log) {
    // A single value near either end of the double range (1e-323, 1e308) widened out of it: keep the
    // value itself as that end of the axis and a decade on the other side.
    if (!(axis.lo > 0)) axis.lo = data_lo;
    if (!std::isfinite(axis.hi)) axis.hi = data_hi;
    if (!(axis.lo < axis.hi)) {
      if (axis.hi < 1)
        axis.hi = axis.lo * 10;
      else
        axis.lo = axis.hi / 10;
    }
  }
  axis.ticks = log ? log_ticks(axis.lo, axis.hi) : linear_ticks(axis.lo, axis.hi);
  return axis;
}

std::vector<std::string> plot_tick_labels(const PlotAxis& axis) {
  const std::vector<double>& ticks = axis.ticks;
  const bool log = axis.log;
  if (ticks.empty()) return {};
  double gap = kInf, max_abs = 0, min_abs = kInf;
  for (size_t i = 0; i < ticks.size(); ++i) {
    if (i + 1 < ticks.size()) gap = std::min(gap, ticks[i + 1] - ticks[i]);
    max_abs = std::max(max_abs, std::abs(ticks[i]));
    if (ticks[i] != 0) min_abs = std::min(min_abs, std::abs(ticks[i]));
  }
  if (!std::isfinite(gap)) gap = max_abs > 0 ? max_abs : 1;
  const bool fixed = max_abs < 1e6 && min_abs >= 1e-4;
  auto format = [&](double v, int precision) {
    char buffer[64];
    if (!fixed && v == 0) return std::string("0");
    std::snprintf(buffer, sizeof(buffer), fixed ? "%.*f" : "%.*e", precision, v);
    return std::string(buffer);
  };
  auto reads_back = [](const std::string& text, double v, double tolerance) {
    return std::abs(std::strtod(text.c_str(), nullptr) - v) <= tolerance;
  };
  std::vector<std::string> labels(ticks.size());
  for (int precision = 0; precision <= 17; ++precision) {
    bool all = true;
    for (size_t i = 0; i < ticks.size(); ++i) {
      if (log && precision > 0 && reads_back(labels[i], ticks[i], 1e-6 * std::abs(ticks[i]))) continue;
      labels[i] = format(ticks[i] == 0 ? 0.0 : ticks[i], precision);  // no "-0"
      all = all && reads_back(labels[i], ticks[i], 1e-6 * (log ? std::abs(ticks[i]) : gap));
    }
    if (all) break;
  }
  for (auto& l : labels) l = tidy_exponent(l);
  return labels;
}

cv::Scalar plot_color(size_t index) {
  // Okabe & Ito (2008) colour-blind-safe palette as BGR; yellow last, it is the faintest on white.
  // Four darker colours follow, so that up to 12 series are told apart by colour alone.
  static const cv::Scalar palette[12] = {
      {178, 114, 0},    // blue
      {0, 94, 213},     // vermillion
      {115, 158, 0},    // bluish green
      {0, 159, 230},    // orange
      {167, 121, 204},  // reddish purple
      {233, 180, 86},   // sky blue
      {0, 0, 0},        // black
      {66, 228, 240},   // yellow
      {19, 69, 139},    // brown
      {0, 100, 0},      // dark green
      {112, 0, 112},    // dark purple
      {128, 0, 0},      // navy
  };
  return palette[index % 12];
}

PlotLayout plot_layout(const std::vector<PlotSeries>& series, const PlotSpec& spec) {
  validate(series, spec);
  std::vector<double> xs, ys;
  for (const auto& s : series)
    for (size_t i = 0; i < s.x.size(); ++i)
      if (drawable(s.x[i], spec.log_x) && drawable(s.y[i], spec.log_y)) {
        xs.push_back(s.x[i]);
        ys.push_back(s.y[i]);
      }
  PlotLayout layout;
  layout.x = make_plot_axis(xs, spec.log_x);
  layout.y = make_plot_axis(ys, spec.log_y);
  const Style st = style_for(spec);
  const Margins m = margins_for(spec, st, plot_tick_labels(layout.x), plot_tick_labels(layout.y));
  layout.area = cv::Rect(m.left, m.top, spec.width - m.left - m.right, spec.height - m.top - m.bottom);
  // 40 pixels: room for a couple of ticks; only tiny charts with long tick labels fall short.
  require(layout.area.width >= 40 && layout.area.height >= 40,
          "plot: " + std::to_string(spec.width) + " x " + std::to_string(spec.height) +
              " pixels leave no room for the plot area");
  layout.legend = place_legend(layout, series, st);
  return layout;
}

cv::Point2d plot_to_pixel(const PlotLayout& layout, double x, double y) {
  if (!drawable(x, layout.x.log) || !drawable(y, layout.y.log)) return {kNaN, kNaN};
  auto fraction = [](const PlotAxis& a, double v) {
    const double lo = to_axis(a.lo, a.log), hi = to_axis(a.hi, a.log);
    return (to_axis(v, a.log) - lo) / (hi - lo);
  };
  const cv::Rect& r = layout.area;
  return {r.x + fraction(layout.x, x) * (r.width - 1), r.y + (1 - fraction(layout.y, y)) * (r.height - 1)};
}

cv::Point2d plot_to_pixel(const std::vector<PlotSeries>& series, const PlotSpec& spec, double x, double y) {
  return plot_to_pixel(plot_layout(series, spec), x, y);
}

cv::Mat draw_plot(const std::vector<PlotSeries>& series, const PlotSpec& spec) {
  const PlotLayout layout = plot_layout(series, spec);
  const Style st = style_for(spec);
  const cv::Rect& a = layout.area;
  const int right = a.x + a.width - 1, bottom = a.y + a.height - 1;
  cv::Mat image(spec.height, spec.width, CV_8UC3, kBackground);

  // Grid, tick marks and tick labels.
  const int tick_ascent = text_ascent(st.tick_font, st.thickness);
  const auto x_labels = plot_tick_labels(layout.x);
  for (size_t i = 0; i < layout.x.ticks.size(); ++i) {
    const int px = int(std::lround(plot_to_pixel(layout, layout.x.ticks[i], layout.y.hi).x));
    cv::line(image, {px, a.y}, {px, bottom}, kGrid, 1);
    cv::line(image, {px, bottom}, {px, bottom + st.tick_len}, kAxis, 1);
    const int w = text_extent(x_labels[i], st.tick_font, st.thickness).width;
    put_text(image, x_labels[i], {px - w / 2, bottom + st.tick_len + st.pad / 2 + tick_ascent}, st.tick_font,
             st.thickness);
  }
  const auto y_labels = plot_tick_labels(layout.y);
  for (size_t i = 0; i < layout.y.ticks.size(); ++i) {
    const int py = int(std::lround(plot_to_pixel(layout, layout.x.hi, layout.y.ticks[i]).y));
    cv::line(image, {a.x, py}, {right, py}, kGrid, 1);
    cv::line(image, {a.x - st.tick_len, py}, {a.x, py}, kAxis, 1);
    const int w = text_extent(y_labels[i], st.tick_font, st.thickness).width;
    put_text(image, y_labels[i], {a.x - st.tick_len - st.pad / 2 - w, py + tick_ascent / 2}, st.tick_font,
             st.thickness);
  }
  cv::rectangle(image, a, kAxis, 1);

  // Axis titles and chart title, shrunk to fit when too long.
  if (!spec.x_label.empty()) {
    const double scale = fit_scale(spec.x_label, st.label_font, st.thickness, a.width);
    const cv::Size size = text_extent(spec.x_label, scale, st.thickness);
    put_text(image, spec.x_label, {a.x + a.width / 2 - size.width / 2, spec.height - st.pad - (size.height - text_ascent(scale, st.thickness))},
             scale, st.thickness);
  }
  if (!spec.y_label.empty()) {
    const double scale = fit_scale(spec.y_label, st.label_font, st.thickness, a.height);
    const int height = text_extent(spec.y_label, scale, st.thickness).height;
    put_text_vertical(image, spec.y_label, {st.pad + height / 2, a.y + a.height / 2}, scale, st.thickness);
  }
  if (!spec.title.empty()) {
    const double scale = fit_scale(spec.title, st.title_font, st.title_thickness, spec.width - 2 * st.pad);
    const int width = text_extent(spec.title, scale, st.title_thickness).width;
    put_text(image, spec.title, {std::max(st.pad, a.x + a.width / 2 - width / 2), st.pad + text_ascent(scale, st.title_thickness)},
             scale, st.title_thickness);
  }

  // Series: lines under markers, later series over earlier ones.
  for (size_t i = 0; i < series.size(); ++i) {
    const cv::Scalar color = series[i].color.value_or(plot_color(i));
    for_each_run(layout, series[i], [&](const std::vector<cv::Point2d>& run) {
      if (series[i].lines) draw_polyline(image, run, color, st, series[i].dashed);
      if (series[i].markers)
        for (const auto& p : run) draw_marker(image, p, color, st.marker_radius);
    });
  }

  // Legend: a line sample (with a marker when the series has them) and the label per row.
  if (!layout.legend.empty()) {
    cv::rectangle(image, layout.legend, kBackground, cv::FILLED);
    cv::rectangle(image, layout.legend, kLegendBorder, 1);
    const int row = legend_row_height(st), sample = legend_sample_width(st);
    const int ascent = text_ascent(st.legend_font, st.thickness);
    int y = layout.legend.y + st.pad / 2 + row / 2;
    for (const auto& e : legend_entries(series)) {
      const cv::Scalar color = e.series->color.value_or(plot_color(e.index));
      const cv::Point2d from(layout.legend.x + st.pad, y), to(layout.legend.x + st.pad + sample, y);
      if (e.series->lines || !e.series->markers) draw_polyline(image, {from, to}, color, st, e.series->dashed);
      if (e.series->markers) draw_marker(image, (from + to) * 0.5, color, st.marker_radius);
      put_text(image, e.series->label, {int(to.x) + st.pad / 2, y + ascent / 2}, st.legend_font, st.thickness);
      y += row;
    }
  }
  return image;
}

void write_plot_png(const std::string& path, const std::vector<PlotSeries>& series, const PlotSpec& spec) {
  cv::Mat image;
  try {
    image = draw_plot(series, spec);
  } catch (const Error& e) {
    throw Error(path + ": " + e.what());
  }
  std::vector<uchar> png;
  require(cv::imencode(".png", image, png), path + ": cannot encode PNG");
  write_file_atomic(path, std::string(png.begin(), png.end()));
}

}  // namespace handscs
