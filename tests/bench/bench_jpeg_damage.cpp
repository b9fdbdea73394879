// handscs-bench-jpeg_damage: what the walk of the coded data (core/jpeg_entropy.h) and libjpeg's own
// errors and warnings (libjpeg_damage, core/jpeg_damage.h) each find, over a corpus of damaged
// files built at run time from the six files the JPEG tests use (four 96x64 OpenCV encodes:
// default, quality 100, restart interval 2, progressive; a grey one; the InterHand2.6M image69148,
// progressive) and a restart-interval re-encode of that image. Per damage class: files flagged by
// each, by one only (with examples and what OpenCV decodes for them: is the damage a grey tail?),
// and by neither (how much of the image OpenCV's decode changes). Classes: every cut (the file ends
// at each byte), every cut of the coded data closed with an end-of-image marker (as the tests cut),
// single-bit flips (every bit, or --max-flips of them drawn with a fixed seed), one byte set to a
// random value, restart markers renumbered, and the undamaged files (false positives).
// "walker_only" is what the check (jpeg_damage: libjpeg, then the walk) finds beyond libjpeg.
// Prints one JSON object.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "core/atomic_file.h"
#include "core/cli.h"
#include "core/jpeg_damage.h"
#include "core/jpeg_entropy.h"
#include "core/logging.h"
#include "core/threads.h"

namespace {

struct File {
  std::string name, bytes;
  cv::Mat decoded = cv::Mat();  // OpenCV's decode of the whole file
};

std::string encode(const cv::Mat& image, const std::vector<int>& params = {}) {
  std::vector<uint8_t> bytes;
  if (!cv::imencode(".jpg", image, bytes, params)) throw std::runtime_error("imencode failed");
  return std::string(bytes.begin(), bytes.end());
}

cv::Mat decode(const std::string& bytes) {
  const cv::Mat encoded(1, static_cast<int>(bytes.size()), CV_8UC1, const_cast<char*>(bytes.data()));
  try {
    return cv::imdecode(encoded, cv::IMREAD_COLOR);
  } catch (const cv::Exception&) {
    return {};
  }
}

// Offset of the first entropy-coded byte (after the first SOS segment).
size_t scan_start(const std::string& jpeg) {
  const size_t sos = jpeg.find("\xFF\xDA");
  const size_t length = (static_cast<uint8_t>(jpeg[sos + 2]) << 8) | static_cast<uint8_t>(jpeg[sos + 3]);
  return sos + 2 + length;
}

// What OpenCV makes of a damaged file, against its decode of the whole one: decoded at all, the
// fraction of pixels off by more than 8 levels, and the bottom rows that are flat grey (libjpeg's
// fill for blocks it could not decode) where the whole image's are not.
nlohmann::json opencv_view(const std::string& damaged, const cv::Mat& whole) {
  const cv::Mat image = decode(damaged);
  if (image.empty()) return {{"decoded", false}};
  if (image.size() != whole.size()) return {{"decoded", true}, {"size_changed", true}};
  cv::Mat diff, channel_max;
  cv::absdiff(image, whole, diff);
  cv::Mat gray_diff = diff.reshape(1, static_cast<int>(diff.total()));
  cv::reduce(gray_diff, channel_max, 1, cv::REDUCE_MAX);
  const double changed = static_cast<double>(cv::countNonZero(channel_max > 8)) / static_cast<double>(image.total());
  int grey_rows = 0;
  for (int y = image.rows - 1; y >= 0; --y) {
    const auto flat_grey = [](const cv::Mat& row) {
      double lo, hi;
      cv::minMaxLoc(row.reshape(1), &lo, &hi);
      return lo >= 120 && hi <= 136 && hi - lo <= 2;
    };
    if (!flat_grey(image.row(y)) || flat_grey(whole.row(y))) break;
    ++grey_rows;
  }
  return {{"decoded", true}, {"changed_pixel_fraction", changed}, {"grey_tail_rows", grey_rows}};
}

// Digits dropped: messages of one kind (block numbers and bytes aside) count together.
std::string kind_of(const std::string& message) {
  std::string out;
  for (char c : message)
    if (!std::isdigit(static_cast<unsigned char>(c))) out += c;
  return out;
}

struct ClassTally {
  int64_t total = 0, walker = 0, libjpeg = 0, both = 0, neither = 0;
  std::vector<nlohmann::json> walker_only, libjpeg_only;
  int64_t walker_only_count = 0, libjpeg_only_count = 0;
  std::map<std::string, int64_t> walker_kinds, libjpeg_kinds, walker_only_kinds, libjpeg_only_kinds;
  // Files flagged by neither whose OpenCV decode was compared with the whole file's (up to
  // kNeitherSample per file and class): how many change more than 1% of the pixels, the largest.
  int64_t neither_compared = 0, neither_over_1pct = 0;
  double neither_max_changed = 0;
  // Every file flagged by one only, decoded by OpenCV: [0] walker only, [1] libjpeg only.
  struct Decoded {
    int64_t failed = 0, grey_tail = 0, over_1pct = 0;
    std::vector<double> changed;
  } one_sided[2];
};

nlohmann::json to_json(const ClassTally::Decoded& d) {
  std::vector<double> changed = d.changed;
  std::sort(changed.begin(), changed.end());
  return {{"not_decoded", d.failed},
          {"decoded", changed.size()},
          {"grey_tail", d.grey_tail},
          {"over_1pct_pixels_changed", d.over_1pct},
          {"median_changed_pixel_fraction", changed.empty() ? 0.0 : changed[changed.size() / 2]}};
}

constexpr int kExamples = 5;         // examples kept per class for each one-sided outcome
constexpr int kNeitherSample = 300;  // undetected files per class and file decoded by OpenCV

void tally(ClassTally& t, const File& file, const std::string& damage, const std::string& bytes, int& neither_left) {
  const std::string walker = handscs::jpeg_entropy_problem(bytes);
  const std::string libjpeg = handscs::libjpeg_damage(bytes);
  ++t.total;
  t.walker += !walker.empty();
  t.libjpeg += !libjpeg.empty();
  if (!walker.empty()) ++t.walker_kinds[kind_of(walker)];
  if (!libjpeg.empty()) ++t.libjpeg_kinds[kind_of(libjpeg)];
  if (!walker.empty() && !libjpeg.empty()) {
    ++t.both;
  } else if (walker.empty() && libjpeg.empty()) {
    ++t.neither;
    if (neither_left-- > 0) {
      const nlohmann::json view = opencv_view(bytes, file.decoded);
      ++t.neither_compared;
      const double changed = view.value("changed_pixel_fraction", 1.0);
      t.neither_over_1pct += changed > 0.01;
      t.neither_max_changed = std::max(t.neither_max_changed, changed);
    }
  } else {
    auto& examples = walker.empty() ? t.libjpeg_only : t.walker_only;
    ++(walker.empty() ? t.libjpeg_only_count : t.walker_only_count);
    ++(walker.empty() ? t.libjpeg_only_kinds[kind_of(libjpeg)] : t.walker_only_kinds[kind_of(walker)]);
    const nlohmann::json view = opencv_view(bytes, file.decoded);
    auto& decoded = t.one_sided[walker.empty() ? 1 : 0];
    if (!view["decoded"].get<bool>()) {
      ++decoded.failed;
    } else {
      const double changed = view.value("changed_pixel_fraction", 1.0);
      decoded.changed.push_back(changed);
      decoded.over_1pct += changed > 0.01;
      decoded.grey_tail += view.value("grey_tail_rows", 0) > 0;
    }
    if (static_cast<int>(examples.size()) < kExamples)
      examples.push_back({{"file", file.name}, {"damage", damage}, {"walker", walker}, {"libjpeg", libjpeg}, {"opencv", view}});
  }
}

nlohmann::json to_json(const ClassTally& t) {
  return {{"files", t.total},
          {"walker", t.walker},
          {"libjpeg", t.libjpeg},
          {"both", t.both},
          {"walker_only", t.walker_only_count},
          {"libjpeg_only", t.libjpeg_only_count},
          {"neither", t.neither},
          {"walker_only_examples", t.walker_only},
          {"libjpeg_only_examples", t.libjpeg_only},
          {"walker_kinds", t.walker_kinds},
          {"libjpeg_kinds", t.libjpeg_kinds},
          {"walker_only_kinds", t.walker_only_kinds},
          {"walker_only_decoded_by_opencv", to_json(t.one_sided[0])},
          {"libjpeg_only_decoded_by_opencv", to_json(t.one_sided[1])},
          {"libjpeg_only_kinds", t.libjpeg_only_kinds},
          {"neither_decoded_by_opencv", {{"compared", t.neither_compared},
                                         {"over_1pct_pixels_changed", t.neither_over_1pct},
                                         {"max_changed_pixel_fraction", t.neither_max_changed}}}};
}

}  // namespace

int main(int argc, char** argv) {
  handscs::log_to_stderr();  // stdout carries the JSON only
  CLI::App app{"handscs-bench-jpeg_damage: the walk of JPEG coded data against libjpeg's warnings on damaged files"};
  handscs::CommonOptions common;
  handscs::add_common_options(app, common, false);
  const std::string samples = std::string(HANDSCS_SHARED_DIR) + "/testdata/interhand2.6m/";
  int64_t max_flips = 20000;
  int random_bytes = 2000;
  app.add_option("--max-flips", max_flips, "bit flips per file: every bit when it has no more, else this many drawn (0: every bit)")
      ->capture_default_str();
  app.add_option("--random-bytes", random_bytes, "bytes set to a random value per file")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  try {
    handscs::start_up(common, "handscs-bench-jpeg_damage");
    handscs::set_threads(1);
    cv::RNG rng(2026);  // a fixed seed: the same corpus on every machine
    cv::Mat texture(64, 96, CV_8UC3);
    rng.fill(texture, cv::RNG::UNIFORM, cv::Scalar::all(0), cv::Scalar::all(255));
    cv::GaussianBlur(texture, texture, cv::Size(3, 3), 0);
    cv::Mat grey;
    cv::cvtColor(texture, grey, cv::COLOR_BGR2GRAY);
    const std::string interhand = handscs::read_file(samples + "image69148.jpg");
    std::vector<File> files = {{"colour_96x64", encode(texture)},
                               {"quality100_96x64", encode(texture, {cv::IMWRITE_JPEG_QUALITY, 100})},
                               {"restart2_96x64", encode(texture, {cv::IMWRITE_JPEG_RST_INTERVAL, 2})},
                               {"progressive_96x64", encode(texture, {cv::IMWRITE_JPEG_PROGRESSIVE, 1})},
                               {"grey_96x64", encode(grey)},
                               {"interhand_image69148", interhand},
                               {"interhand_image69148_restart4", encode(decode(interhand), {cv::IMWRITE_JPEG_RST_INTERVAL, 4})}};
    for (auto& f : files) f.decoded = decode(f.bytes);

    std::map<std::string, ClassTally> classes;
    nlohmann::json undamaged = nlohmann::json::array();
    const auto check_whole = [&](const std::string& name, const std::string& bytes) {
      undamaged.push_back({{"file", name},
                           {"bytes", bytes.size()},
                           {"walker", handscs::jpeg_entropy_problem(bytes)},
                           {"libjpeg", handscs::libjpeg_damage(bytes)}});
    };
    for (const auto& f : files) {
      check_whole(f.name, f.bytes);
      check_whole(f.name + "+16_trailing_zero_bytes", f.bytes + std::string(16, '\0'));
    }
    for (const char* other : {"image2017.jpg", "image29590.jpg", "image44669.jpg"})
      check_whole(std::string("interhand_") + other, handscs::read_file(samples + other));
    check_whole("progressive_restart3_96x64",
                encode(texture, {cv::IMWRITE_JPEG_PROGRESSIVE, 1, cv::IMWRITE_JPEG_RST_INTERVAL, 3}));
    check_whole("grey_progressive_96x64", encode(grey, {cv::IMWRITE_JPEG_PROGRESSIVE, 1}));

    for (const auto& f : files) {
      spdlog::info("{}: {} bytes", f.name, f.bytes.size());
      const std::string& jpeg = f.bytes;
      const size_t start = scan_start(jpeg), end = jpeg.rfind("\xFF\xD9");
      std::map<std::string, int> neither_left;
      const auto run = [&](const std::string& cls, const std::string& damage, const std::string& bytes) {
        auto it = neither_left.try_emplace(cls, kNeitherSample).first;
        tally(classes[cls], f, damage, bytes, it->second);
      };
      // The file ends at every byte before its last.
      for (size_t cut = 0; cut < jpeg.size(); ++cut) run("cut", "cut at " + std::to_string(cut), jpeg.substr(0, cut));
      // The coded data cut and closed with an end-of-image marker, as the tests cut it.
      for (size_t cut = start; cut < end; ++cut) {
        if (static_cast<uint8_t>(jpeg[cut - 1]) == 0xFF) continue;
        if (static_cast<uint8_t>(jpeg[cut]) == 0xFF && static_cast<uint8_t>(jpeg[cut + 1]) != 0x00) continue;
        run("cut_closed_with_eoi", "cut at " + std::to_string(cut) + " + FFD9", jpeg.substr(0, cut) + "\xFF\xD9");
      }
      // Single-bit flips: in the headers before the first coded byte, and from there on.
      const int64_t bits = static_cast<int64_t>(jpeg.size()) * 8;
      const bool every = max_flips == 0 || bits <= max_flips;
      const int64_t flips = every ? bits : max_flips;
      for (int64_t k = 0; k < flips; ++k) {
        const int64_t bit = every ? k : static_cast<int64_t>(rng.uniform(0.0, 1.0) * static_cast<double>(bits));
        const size_t at = static_cast<size_t>(bit / 8);
        std::string copy = jpeg;
        copy[at] = static_cast<char>(static_cast<uint8_t>(copy[at]) ^ (1u << (bit % 8)));
        run(at < start ? "bit_flip_headers" : "bit_flip_data",
            "byte " + std::to_string(at) + " bit " + std::to_string(bit % 8), copy);
      }
      // One byte of the coded data set to a random value (skipping values that leave it as it was).
      for (int k = 0; k < random_bytes; ++k) {
        const size_t at = start + static_cast<size_t>(rng.uniform(0, static_cast<int>(end - start)));
        const int value = rng.uniform(0, 256);
        if (value == static_cast<uint8_t>(jpeg[at])) continue;
        std::string copy = jpeg;
        copy[at] = static_cast<char>(value);
        run("random_byte_data", "byte " + std::to_string(at) + " := " + std::to_string(value), copy);
      }
      // Restart markers renumbered: each RSTn in the coded data replaced by each other RSTm.
      for (size_t at = start; at + 1 < end; ++at) {
        if (static_cast<uint8_t>(jpeg[at]) != 0xFF) continue;
        const uint8_t code = static_cast<uint8_t>(jpeg[at + 1]);
        if (code < 0xD0 || code > 0xD7) continue;
        for (uint8_t other = 0xD0; other <= 0xD7; ++other) {
          if (other == code) continue;
          std::string copy = jpeg;
          copy[at + 1] = static_cast<char>(other);
          run("restart_renumbered", "RST at " + std::to_string(at) + " -> " + std::to_string(other - 0xD0), copy);
        }
      }
    }

    nlohmann::json out;
    out["bench"] = "jpeg_damage";
    out["max_flips"] = max_flips;
    out["random_bytes"] = random_bytes;
    for (const auto& f : files) out["files"].push_back({{"file", f.name}, {"bytes", f.bytes.size()}});
    out["undamaged"] = undamaged;
    for (const auto& [name, t] : classes) out["classes"][name] = to_json(t);
    std::printf("%s\n", out.dump(2).c_str());
    return 0;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}
