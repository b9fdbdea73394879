// Charts: tick choice on known and random ranges, the data-to-pixel mapping (checked against the
// drawn pixels' colours), log axes, skipped points, legend placement and the PNG writer.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <limits>
#include <random>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "core/error.h"
#include "sweep/pareto.h"
#include "sweep/plot.h"

using Catch::Matchers::WithinAbs;
using Catch::Matchers::WithinRel;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

handscs::PlotSeries points(std::vector<double> x, std::vector<double> y, std::string label = "") {
  handscs::PlotSeries s;
  s.label = std::move(label);
  s.x = std::move(x);
  s.y = std::move(y);
  return s;
}

cv::Vec3b pixel_at(const cv::Mat& image, const cv::Point2d& p) {
  return image.at<cv::Vec3b>(int(std::lround(p.y)), int(std::lround(p.x)));
}

// Largest per-channel difference between a pixel and a BGR colour.
int color_distance(const cv::Vec3b& v, const cv::Scalar& c) {
  int d = 0;
  for (int k = 0; k < 3; ++k) d = std::max(d, std::abs(int(v[k]) - int(c[k])));
  return d;
}

int count_color(const cv::Mat& image, const cv::Rect& region, const cv::Scalar& color, int tolerance) {
  int n = 0;
  for (int r = region.y; r < region.y + region.height; ++r)
    for (int c = region.x; c < region.x + region.width; ++c)
      if (color_distance(image.at<cv::Vec3b>(r, c), color) <= tolerance) ++n;
  return n;
}

const cv::Scalar kWhite(255, 255, 255);
const cv::Scalar kOkabeBlue(178, 114, 0);        // BGR of Okabe-Ito blue (0, 114, 178)
const cv::Scalar kOkabeVermillion(0, 94, 213);   // BGR of Okabe-Ito vermillion (213, 94, 0)

}  // namespace

TEST_CASE("make_plot_axis: known ranges give the expected ticks and a 5% margin", "[plot]") {
  const auto linear = handscs::make_plot_axis({0, 10, 3}, false);
  CHECK_THAT(linear.lo, WithinAbs(-0.5, 1e-12));
  CHECK_THAT(linear.hi, WithinAbs(10.5, 1e-12));
  CHECK(linear.ticks == std::vector<double>{0, 2, 4, 6, 8, 10});

  // log10 range [0, 3] plus 0.15 decades each side: decade ticks.
  const auto decades = handscs::make_plot_axis({1, 1000, 20}, true);
  CHECK_THAT(decades.lo, WithinRel(std::pow(10.0, -0.15), 1e-12));
  CHECK_THAT(decades.hi, WithinRel(std::pow(10.0, 3.15), 1e-12));
  CHECK(decades.ticks == std::vector<double>{1, 10, 100, 1000});

  // Under 3 decades: 1-2-5 values.
  const auto short_log = handscs::make_plot_axis({1, 50}, true);
  CHECK(short_log.ticks == std::vector<double>{1, 2, 5, 10, 20, 50});

  // Step 2 gives 9 ticks in [5.53, 22.47] and step 5 gives 3: the range grows down to 5.
  const auto awkward = handscs::make_plot_axis({6.3, 21.7}, false);
  CHECK(awkward.lo == 5.0);
  CHECK_THAT(awkward.hi, WithinAbs(22.47, 1e-12));
  CHECK(awkward.ticks == std::vector<double>{5, 10, 15, 20});

  // 0.1 steps come out as the doubles nearest the decimal values (no 0.30000000000000004).
  const auto single = handscs::make_plot_axis({3}, false);  // [2.7, 3.3] plus margin
  CHECK_THAT(single.lo, WithinAbs(2.67, 1e-12));
  CHECK_THAT(single.hi, WithinAbs(3.33, 1e-12));
  CHECK(single.ticks == std::vector<double>{2.7, 2.8, 2.9, 3.0, 3.1, 3.2, 3.3});

  // No usable values: [0, 1] (decades 1..10 on a log axis) plus margin; zero gets +-1.
  const auto empty = handscs::make_plot_axis({kNaN, -kInf}, false);
  CHECK_THAT(empty.lo, WithinAbs(-0.05, 1e-12));
  CHECK_THAT(empty.hi, WithinAbs(1.05, 1e-12));
  const auto empty_log = handscs::make_plot_axis({0, -3}, true);
  CHECK_THAT(empty_log.lo, WithinRel(std::pow(10.0, -0.05), 1e-12));
  const auto zero = handscs::make_plot_axis({0, 0}, false);
  CHECK_THAT(zero.lo, WithinAbs(-1.1, 1e-12));
  CHECK_THAT(zero.hi, WithinAbs(1.1, 1e-12));
}

TEST_CASE("plot_tick_labels: the shortest text that reads back, no -0, exponents for extremes", "[plot]") {
  using Labels = std::vector<std::string>;
  CHECK(handscs::plot_tick_labels(handscs::make_plot_axis({0, 10}, false)) == Labels{"0", "2", "4", "6", "8", "10"});
  // Linear ticks share their decimals.
  CHECK(handscs::plot_tick_labels(handscs::make_plot_axis({3}, false)) ==
        Labels{"2.7", "2.8", "2.9", "3.0", "3.1", "3.2", "3.3"});
  CHECK(handscs::plot_tick_labels(handscs::make_plot_axis({-1, 1}, false)) ==
        Labels{"-1.0", "-0.5", "0.0", "0.5", "1.0"});
  CHECK(handscs::plot_tick_labels(handscs::make_plot_axis({0, 4e6}, false)) ==
        Labels{"0", "1e6", "2e6", "3e6", "4e6"});
  // Log ticks are shortened one by one.
  CHECK(handscs::plot_tick_labels(handscs::make_plot_axis({1, 50}, true)) == Labels{"1", "2", "5", "10", "20", "50"});
  handscs::PlotAxis log_axis;
  log_axis.log = true;
  log_axis.lo = 0.4;
  log_axis.hi = 25;
  log_axis.ticks = {0.5, 1, 2, 5, 10, 20};
  CHECK(handscs::plot_tick_labels(log_axis) == Labels{"0.5", "1", "2", "5", "10", "20"});
  CHECK(handscs::plot_tick_labels(handscs::make_plot_axis({1e-6, 1}, true)) ==
        Labels{"1e-6", "1e-5", "1e-4", "1e-3", "1e-2", "1e-1", "1e0"});
  // 9 decades are more than 8 ticks: every second one (even exponents).
  CHECK(handscs::plot_tick_labels(handscs::make_plot_axis({1e-4, 1e4}, true)) ==
        Labels{"0.0001", "0.01", "1", "100", "10000"});
}

TEST_CASE("make_plot_axis: random ranges get 4-8 evenly spaced 1-2-5 ticks around the data", "[plot]") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 2000; ++trial) {
    const double span = std::pow(10.0, -6 + 12 * unit(rng));
    const double a = (unit(rng) - 0.5) * 20 * span, b = a + span;
    const auto axis = handscs::make_plot_axis({b, a}, false);
    INFO("data [" << a << ", " << b << "] axis [" << axis.lo << ", " << axis.hi << "]");
    REQUIRE(axis.ticks.size() >= 4);
    REQUIRE(axis.ticks.size() <= 8);
    CHECK(axis.lo < a);
    CHECK(axis.hi > b);
    CHECK(axis.ticks.front() >= axis.lo);
    CHECK(axis.ticks.back() <= axis.hi);
    const double step = axis.ticks[1] - axis.ticks[0];
    const double mantissa = step / std::pow(10.0, std::floor(std::log10(step) + 1e-9));
    CHECK((std::abs(mantissa - 1) < 1e-6 || std::abs(mantissa - 2) < 1e-6 || std::abs(mantissa - 5) < 1e-6));
    for (size_t i = 1; i < axis.ticks.size(); ++i)
      CHECK_THAT(axis.ticks[i] - axis.ticks[i - 1], WithinRel(step, 1e-6));
    for (double t : axis.ticks) CHECK(std::abs(t / step - std::round(t / step)) < 1e-6);
    // The range is the data plus 5% each side, grown to a tick only on one side when needed.
    const bool plain = std::abs(axis.lo - (a - 0.05 * span)) < 1e-9 * span &&
                       std::abs(axis.hi - (b + 0.05 * span)) < 1e-9 * span;
    CHECK((plain || axis.lo == axis.ticks.front() || axis.hi == axis.ticks.back()));
  }
}

TEST_CASE("make_plot_axis: extreme and degenerate values still give a valid axis", "[plot]") {
  const std::vector<std::pair<std::vector<double>, bool>> cases = {
      {{1.0, 1.0 + 1e-14}, false}, {{1.0, 1.0 + 1e-14}, true},   {{1e-310, 2e-310}, false},
      {{1e-310, 2e-310}, true},    {{-1e308, 1e308}, false},      {{1e300, 1e308}, true},
      {{1e15, 1e15 + 1}, false},   {{-7.5, -7.5}, false},         {{1e-300, 1e300}, true},
      {{5e-324}, true},            {{1.7e308}, true},              {{-1e-3, -1e-3 + 1e-12}, false}};
  for (const auto& [values, log] : cases) {
    const auto axis = handscs::make_plot_axis(values, log);
    INFO("values " << values.front() << ".." << values.back() << " log " << log << " axis [" << axis.lo << ", "
                   << axis.hi << "] ticks " << axis.ticks.size());
    CHECK(std::isfinite(axis.lo));
    CHECK(std::isfinite(axis.hi));
    CHECK(axis.lo < axis.hi);
    if (log) CHECK(axis.lo > 0);
    CHECK(axis.lo <= values.front());
    CHECK(axis.hi >= values.back());
    CHECK(axis.ticks.size() <= 8);
    for (double t : axis.ticks) CHECK((t >= axis.lo && t <= axis.hi));
    CHECK(handscs::plot_tick_labels(axis).size() == axis.ticks.size());
  }
  // A range at 1e15 with spread 1 still gets 1-2-5 ticks (integers here).
  const auto far = handscs::make_plot_axis({1e15, 1e15 + 1}, false);
  CHECK(far.ticks.size() >= 4);
  // Huge ranges draw without hanging.
  const std::vector<handscs::PlotSeries> huge = {points({-1e308, 1e308}, {1e-300, 1e300})};
  handscs::PlotSpec spec;
  spec.log_y = true;
  CHECK(handscs::draw_plot(huge, spec).cols == 960);
}

TEST_CASE("draw_plot returns a BGR image of the requested size", "[plot]") {
  const std::vector<handscs::PlotSeries> series = {points({1, 2, 3}, {4, 1, 9}, "a")};
  handscs::PlotSpec spec;
  const cv::Mat image = handscs::draw_plot(series, spec);
  CHECK(image.type() == CV_8UC3);
  CHECK(image.cols == 960);
  CHECK(image.rows == 640);
  spec.width = 400;
  spec.height = 300;
  spec.title = "a title";
  spec.x_label = "x";
  spec.y_label = "y";
  const cv::Mat small = handscs::draw_plot(series, spec);
  CHECK(small.cols == 400);
  CHECK(small.rows == 300);
  CHECK(color_distance(small.at<cv::Vec3b>(0, 0), kWhite) == 0);
}

TEST_CASE("a one-point series draws its colour at plot_to_pixel and nowhere far from it", "[plot]") {
  const std::vector<handscs::PlotSeries> series = {points({2.5}, {7})};
  handscs::PlotSpec spec;
  spec.title = "one point";
  spec.x_label = "seconds";
  spec.y_label = "PSNR";
  const cv::Mat image = handscs::draw_plot(series, spec);
  const auto layout = handscs::plot_layout(series, spec);
  const cv::Point2d p = handscs::plot_to_pixel(series, spec, 2.5, 7);
  // A single point sits in the middle of a symmetric range: the centre of the axes box.
  CHECK_THAT(p.x, WithinAbs(layout.area.x + (layout.area.width - 1) / 2.0, 1e-6));
  CHECK_THAT(p.y, WithinAbs(layout.area.y + (layout.area.height - 1) / 2.0, 1e-6));
  CHECK(handscs::plot_color(0) == kOkabeBlue);
  CHECK(color_distance(pixel_at(image, p), kOkabeBlue) <= 2);
  // Every pixel of that colour is within the marker (4 px at this size, plus anti-aliasing).
  int blue = 0;
  for (int r = 0; r < image.rows; ++r)
    for (int c = 0; c < image.cols; ++c)
      if (color_distance(image.at<cv::Vec3b>(r, c), kOkabeBlue) <= 10) {
        ++blue;
        CHECK(std::hypot(c - p.x, r - p.y) <= 5.5);
      }
  CHECK(blue >= 25);  // about pi 4^2 pixels
  // An explicit colour replaces the palette's.
  auto grey = series;
  grey[0].color = cv::Scalar(150, 150, 150);
  CHECK(color_distance(pixel_at(handscs::draw_plot(grey, spec), p), cv::Scalar(150, 150, 150)) <= 2);
  // Between the first two grid lines both ways (far from the point): background white.
  const auto& xt = layout.x.ticks;
  const auto& yt = layout.y.ticks;
  REQUIRE(xt.size() >= 4);
  REQUIRE(yt.size() >= 4);
  const cv::Point2d empty = handscs::plot_to_pixel(layout, 0.5 * (xt[0] + xt[1]), 0.5 * (yt[0] + yt[1]));
  CHECK(std::hypot(empty.x - p.x, empty.y - p.y) > 100);
  CHECK(color_distance(pixel_at(image, empty), kWhite) == 0);
}

TEST_CASE("plot_to_pixel is linear, x to the right and y upwards, and series get distinct colours", "[plot]") {
  const std::vector<handscs::PlotSeries> series = {points({0}, {0}), points({10}, {5})};
  const handscs::PlotSpec spec;
  const cv::Mat image = handscs::draw_plot(series, spec);
  const cv::Point2d a = handscs::plot_to_pixel(series, spec, 0, 0);
  const cv::Point2d b = handscs::plot_to_pixel(series, spec, 10, 5);
  const cv::Point2d mid = handscs::plot_to_pixel(series, spec, 5, 2.5);
  CHECK(b.x > a.x + 500);
  CHECK(b.y < a.y - 300);
  CHECK_THAT(mid.x, WithinAbs(0.5 * (a.x + b.x), 1e-9));
  CHECK_THAT(mid.y, WithinAbs(0.5 * (a.y + b.y), 1e-9));
  // x range [-0.5, 10.5]: x = 0 is 0.5 / 11 of the way across the axes box.
  const auto layout = handscs::plot_layout(series, spec);
  CHECK_THAT(a.x, WithinAbs(layout.area.x + 0.5 / 11 * (layout.area.width - 1), 1e-9));
  CHECK(handscs::plot_color(1) == kOkabeVermillion);
  CHECK(color_distance(pixel_at(image, a), kOkabeBlue) <= 2);
  CHECK(color_distance(pixel_at(image, b), kOkabeVermillion) <= 2);
  for (size_t i = 0; i < 12; ++i) {
    const cv::Scalar ci = handscs::plot_color(i);
    for (size_t j = 0; j < i; ++j)
      CHECK(color_distance(cv::Vec3b(ci[0], ci[1], ci[2]), handscs::plot_color(j)) > 60);
  }
  CHECK(handscs::plot_color(12) == handscs::plot_color(0));
}

TEST_CASE("log axes map decades to equal pixel spacing and skip non-positive values", "[plot]") {
  handscs::PlotSpec spec;
  spec.log_x = true;
  spec.log_y = true;
  const std::vector<handscs::PlotSeries> series = {
      points({1, 10, 100, 1000, 0, -5}, {1e-3, 1e-2, 1e-1, 1, 1e6, 1e6}, "lpips")};
  const auto layout = handscs::plot_layout(series, spec);
  // (0, 1e6) and (-5, 1e6) are skipped and do not stretch the y axis.
  CHECK(layout.y.hi < 10);
  CHECK(layout.x.lo > 0);
  std::vector<cv::Point2d> p;
  for (double k = 0; k < 4; ++k) p.push_back(handscs::plot_to_pixel(layout, std::pow(10, k), std::pow(10, k - 3)));
  const double dx = p[1].x - p[0].x, dy = p[1].y - p[0].y;
  CHECK(dx > 100);
  CHECK(dy < -100);
  for (int k = 1; k < 3; ++k) {
    CHECK_THAT(p[k + 1].x - p[k].x, WithinAbs(dx, 1e-6));
    CHECK_THAT(p[k + 1].y - p[k].y, WithinAbs(dy, 1e-6));
  }
  const cv::Point2d root = handscs::plot_to_pixel(layout, std::sqrt(10.0), std::sqrt(10.0) * 1e-3);
  CHECK_THAT(root.x, WithinAbs(0.5 * (p[0].x + p[1].x), 1e-6));
  CHECK_THAT(root.y, WithinAbs(0.5 * (p[0].y + p[1].y), 1e-6));
  CHECK(std::isnan(handscs::plot_to_pixel(layout, 0, 1).x));
  CHECK(std::isnan(handscs::plot_to_pixel(layout, 10, -1).y));
  CHECK(layout.x.ticks == std::vector<double>{1, 10, 100, 1000});
  const cv::Mat image = handscs::draw_plot(series, spec);
  for (const auto& q : p) CHECK(color_distance(pixel_at(image, q), kOkabeBlue) <= 2);
}

TEST_CASE("non-finite points are skipped: no crash, no effect on the axes, lines broken there", "[plot]") {
  handscs::PlotSpec spec;
  const std::vector<handscs::PlotSeries> series = {
      points({1, kNaN, 100, kInf, 3, 2}, {1, 5, kNaN, 2, 3, -kInf}, "with gaps")};
  const auto layout = handscs::plot_layout(series, spec);
  CHECK_THAT(layout.x.lo, WithinAbs(0.9, 1e-12));  // drawable points (1, 1) and (3, 3) only
  CHECK_THAT(layout.x.hi, WithinAbs(3.1, 1e-12));
  CHECK_THAT(layout.y.hi, WithinAbs(3.1, 1e-12));
  const cv::Mat image = handscs::draw_plot(series, spec);
  CHECK(color_distance(pixel_at(image, handscs::plot_to_pixel(layout, 1, 1)), kOkabeBlue) <= 2);
  CHECK(color_distance(pixel_at(image, handscs::plot_to_pixel(layout, 3, 3)), kOkabeBlue) <= 2);
  // (1, 1) and (3, 3) are not neighbours in the series: nothing is drawn through (2, 2).
  CHECK(color_distance(pixel_at(image, handscs::plot_to_pixel(layout, 2, 2)), kOkabeBlue) > 60);
  CHECK(std::isnan(handscs::plot_to_pixel(layout, kNaN, 1).x));
  CHECK(std::isnan(handscs::plot_to_pixel(layout, 1, kInf).y));

  // Nothing drawable at all, or no series: still a chart with default axes.
  const std::vector<handscs::PlotSeries> all_nan = {points({kNaN, kNaN}, {1, 2}, "empty")};
  CHECK(handscs::draw_plot(all_nan, spec).cols == 960);
  CHECK(handscs::plot_layout(all_nan, spec).x.ticks.size() >= 4);
  CHECK(handscs::draw_plot({}, spec).rows == 640);
}

TEST_CASE("dashed lines leave gaps, solid lines do not", "[plot]") {
  handscs::PlotSeries line = points({0, 10}, {0, 0});
  line.markers = false;
  handscs::PlotSpec spec;
  for (bool dashed : {false, true}) {
    line.dashed = dashed;
    const std::vector<handscs::PlotSeries> series = {line};
    const cv::Mat image = handscs::draw_plot(series, spec);
    const cv::Point2d a = handscs::plot_to_pixel(series, spec, 0, 0);
    const cv::Point2d b = handscs::plot_to_pixel(series, spec, 10, 0);
    int ink = 0, gaps = 0, dashes = 0;
    bool in_dash = false;
    for (int c = int(a.x) + 2; c <= int(b.x) - 2; ++c) {
      const bool on = color_distance(image.at<cv::Vec3b>(int(std::lround(a.y)), c), kOkabeBlue) <= 40;
      (on ? ink : gaps) += 1;
      dashes += on && !in_dash;
      in_dash = on;
    }
    INFO("dashed " << dashed << " ink " << ink << " gaps " << gaps << " dashes " << dashes);
    if (dashed) {
      // 10 px dashes and 6 px gaps at this size: one dash per 16 px, about 10/16 of the pixels inked
      // (a little more: anti-aliasing at each dash end).
      const double period = 16, length = ink + gaps;
      CHECK(std::abs(dashes - length / period) <= 2);
      CHECK(ink > 0.55 * length);
      CHECK(ink < 0.85 * length);
    } else {
      CHECK(gaps == 0);
      CHECK(dashes == 1);
    }
  }
}

TEST_CASE("the legend sits in a free corner and shows every labelled series", "[plot]") {
  handscs::PlotSeries fast = points({0, 5, 10}, {0, 5, 10}, "fast");
  handscs::PlotSeries front = points({0, 10}, {1, 9}, "Pareto front");
  front.dashed = true;
  const std::vector<handscs::PlotSeries> series = {fast, front, points({5}, {2})};
  handscs::PlotSpec spec;
  const auto layout = handscs::plot_layout(series, spec);
  const cv::Rect& area = layout.area;
  // Both lines run bottom-left to top-right: the top-right corner is taken, top-left is the first free one.
  REQUIRE(!layout.legend.empty());
  CHECK((layout.legend & area) == layout.legend);
  CHECK(layout.legend.x + layout.legend.width < area.x + area.width / 2);
  CHECK(layout.legend.y + layout.legend.height < area.y + area.height / 2);
  for (const auto& s : series)
    for (size_t i = 0; i < s.x.size(); ++i) CHECK(!layout.legend.contains(handscs::plot_to_pixel(layout, s.x[i], s.y[i])));
  const cv::Mat image = handscs::draw_plot(series, spec);
  CHECK(count_color(image, layout.legend, handscs::plot_color(0), 2) > 10);
  CHECK(count_color(image, layout.legend, handscs::plot_color(1), 2) > 10);
  CHECK(count_color(image, layout.legend, handscs::plot_color(2), 2) == 0);  // unlabelled: not listed

  const std::vector<handscs::PlotSeries> unlabelled = {points({0, 1}, {0, 1})};
  CHECK(handscs::plot_layout(unlabelled, spec).legend.empty());
}

TEST_CASE("write_plot_png writes a PNG that reads back as the drawn chart", "[plot]") {
  const auto dir = std::filesystem::temp_directory_path() / "handscs_test_sweep_plot";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "chart.png").string();
  const std::vector<handscs::PlotSeries> series = {points({1, 2, 4}, {30, 31, 31.5}, "psnr")};
  handscs::PlotSpec spec;
  spec.width = 640;
  spec.height = 480;
  spec.title = "PSNR vs time";
  handscs::write_plot_png(path, series, spec);
  const cv::Mat read = cv::imread(path, cv::IMREAD_COLOR);
  REQUIRE(!read.empty());
  CHECK(read.cols == 640);
  CHECK(read.rows == 480);
  CHECK(cv::norm(read, handscs::draw_plot(series, spec), cv::NORM_INF) == 0);
  int entries = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) entries += entry.is_regular_file();
  CHECK(entries == 1);  // no temporary left behind

  const std::string unwritable = (dir / "no_such_folder" / "chart.png").string();
  CHECK_THROWS_AS(handscs::write_plot_png(unwritable, series, spec), handscs::Error);
  CHECK_THROWS_WITH(handscs::write_plot_png(unwritable, series, spec), Catch::Contains(unwritable));
  spec.width = 10;
  CHECK_THROWS_WITH(handscs::write_plot_png(path, series, spec), Catch::StartsWith(path + ": plot: size 10 x 480"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("draw_plot rejects bad sizes and series of unequal lengths", "[plot]") {
  handscs::PlotSpec spec;
  spec.width = 100;
  spec.height = 100;
  CHECK_THROWS_WITH(handscs::draw_plot({}, spec),
                    "plot: size 100 x 100 is outside 160 x 120 .. 16384 x 16384 pixels");
  const std::vector<handscs::PlotSeries> uneven = {points({1, 2}, {1}, "psnr")};
  CHECK_THROWS_WITH(handscs::draw_plot(uneven, handscs::PlotSpec()), "plot: series 'psnr': x has 2 values, y has 1");
  CHECK_THROWS_AS(handscs::plot_to_pixel(uneven, handscs::PlotSpec(), 1, 1), handscs::Error);
}

TEST_CASE("a sweep chart with a dashed Pareto front over many vertices is drawn in full", "[plot]") {
  // Quality against log wall time for 5 settings x 5 budgets and their Pareto front, the way the sweep
  // report draws it. (The dash walk once stalled here when a dash ended a rounding error before a vertex.)
  std::vector<handscs::PlotSeries> series;
  std::vector<double> all_x, all_y;
  for (int p = 0; p < 5; ++p) {
    handscs::PlotSeries s;
    s.label = "setting " + std::to_string(p);
    for (int b = 0; b < 5; ++b) {
      const double t = 0.5 * std::pow(2.0, b) * (1 + 0.3 * p);
      const double q = 24 + 2.2 * std::log2(1 + t) - 0.6 * p + 0.3 * ((p * 7 + b * 3) % 5);
      s.x.push_back(t);
      s.y.push_back(q);
      all_x.push_back(t);
      all_y.push_back(q);
    }
    series.push_back(s);
  }
  handscs::PlotSeries front;
  front.label = "Pareto front";
  front.dashed = true;
  front.markers = false;
  for (size_t i : handscs::pareto_front(all_x, all_y, true)) {
    front.x.push_back(all_x[i]);
    front.y.push_back(all_y[i]);
  }
  REQUIRE(front.x.size() == 9);
  series.push_back(front);
  handscs::PlotSpec spec;
  spec.title = "Novel-pose PSNR against training wall time";
  spec.x_label = "training wall time (min)";
  spec.y_label = "PSNR (dB), higher is better";
  spec.log_x = true;
  const cv::Mat image = handscs::draw_plot(series, spec);
  const auto layout = handscs::plot_layout(series, spec);
  // The front's colour (sky blue, series 5) appears along the front outside the legend.
  cv::Mat outside = image.clone();
  outside(layout.legend).setTo(cv::Scalar(255, 255, 255));
  CHECK(count_color(outside, layout.area, handscs::plot_color(5), 2) > 200);
}
