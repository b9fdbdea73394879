// The image-check cache (data/scan_cache.h): its results equal scan_image's field for field, read or
// scanned; a second open scans nothing; an image whose size or time alone changed is scanned again;
// an unreadable image with no damage named is not stored; a damaged, foreign or other-version cache
// file is ignored and rewritten; entries of images not opened are kept; an unwritable first place
// falls back to the next, whose entries later opens use; a capture opened twice selects the same
// frames and skips the same images, the second time without writing the cache; "off" writes none.
#include <catch2/catch.hpp>

#include <chrono>
#include <filesystem>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/atomic_file.h"
#include "data/capture.h"
#include "data/capture_layout.h"
#include "data/scan_cache.h"
#include "data_test_helpers.h"
#include "synth_fixture.h"

using namespace data_test;
namespace fs = std::filesystem;

namespace {

void check_same(const std::vector<handscs::ImageScan>& got, const std::vector<std::string>& paths) {
  REQUIRE(got.size() == paths.size());
  for (size_t i = 0; i < paths.size(); ++i) {
    INFO(paths[i]);
    const auto want = handscs::scan_image(paths[i]);
    CHECK(got[i].readable == want.readable);
    CHECK(got[i].damage == want.damage);
    CHECK(got[i].black == want.black);
    CHECK(got[i].monochrome == want.monochrome);
    CHECK(got[i].width == want.width);
    CHECK(got[i].height == want.height);
  }
}

std::string write_jpeg(const std::string& path, const cv::Mat& image) {
  fs::create_directories(fs::path(path).parent_path());
  REQUIRE(cv::imwrite(path, image));
  return path;
}

// Images of every kind the checks tell apart: colour (an InterHand2.6M sample), black, grey, a
// damaged JPEG (the sample cut short) and a file that does not exist.
std::vector<std::string> sample_images(const std::string& images) {
  const std::string sample = samples_dir() + "/image2017.jpg";
  const std::string colour = images + "/seq/cam1/colour.jpg";
  fs::create_directories(fs::path(colour).parent_path());
  fs::copy_file(sample, colour);
  const std::string bytes = handscs::read_file(sample);
  return {colour,
          write_jpeg(images + "/seq/cam2/black.jpg", cv::Mat(64, 48, CV_8UC3, cv::Scalar(0, 0, 0))),
          write_jpeg(images + "/seq/cam3/grey.jpg", cv::Mat(64, 48, CV_8UC3, cv::Scalar(90, 90, 90))),
          write_text(images + "/seq/cam4/damaged.jpg", bytes.substr(0, bytes.size() / 2)),
          images + "/seq/cam5/missing.jpg"};
}

}  // namespace

TEST_CASE("scan cache: equal to scan_image, and a second open reads every stored result") {
  const std::string dir = fresh_dir("scan_cache_equal");
  const std::string images = dir + "/images";
  const auto paths = sample_images(images);
  const std::vector<std::string> files{dir + "/cache/images.capture0.scans"};
  handscs::ScanCounts counts;
  check_same(handscs::scan_images(paths, files, images, &counts), paths);
  CHECK(counts.scanned == paths.size());
  CHECK(counts.cached == 0);
  REQUIRE(fs::is_regular_file(files[0]));
  check_same(handscs::scan_images(paths, files, images, &counts), paths);
  CHECK(counts.cached == paths.size() - 1);  // the missing file is never stored
  CHECK(counts.scanned == 1);
}

TEST_CASE("scan cache: an image whose size or time changed is scanned again") {
  const std::string dir = fresh_dir("scan_cache_changed");
  const std::string images = dir + "/images";
  const auto paths = sample_images(images);
  const std::vector<std::string> files{dir + "/cache/c.scans"};
  handscs::ScanCounts counts;
  (void)handscs::scan_images(paths, files, images, &counts);

  // The colour sample replaced by a black image of another size, its old time put back: only the
  // size tells.
  const auto time = fs::last_write_time(paths[0]);
  write_jpeg(paths[0], cv::Mat(334, 512, CV_8UC3, cv::Scalar(0, 0, 0)));
  fs::last_write_time(paths[0], time);
  auto scans = handscs::scan_images(paths, files, images, &counts);
  CHECK(counts.scanned == 2);  // the changed image and the missing one
  CHECK(scans[0].black);
  check_same(scans, paths);

  // Only the time changes, by a microsecond (same bytes): scanned again as well.
  fs::last_write_time(paths[1], fs::last_write_time(paths[1]) + std::chrono::microseconds(1));
  scans = handscs::scan_images(paths, files, images, &counts);
  CHECK(counts.scanned == 2);
  check_same(scans, paths);

  // An unreadable image with no damage named (a .png that is not one: only JPEGs are walked) is
  // checked at every open.
  auto with_broken = paths;
  with_broken.push_back(write_text(images + "/seq/cam6/broken.png", "not an image"));
  for (int open = 0; open < 2; ++open) {
    scans = handscs::scan_images(with_broken, files, images, &counts);
    CHECK_FALSE(scans.back().readable);
    CHECK(scans.back().damage.empty());
    CHECK(counts.scanned == 2);  // it and the missing one
  }
}

TEST_CASE("scan cache: a damaged or foreign cache file is ignored and rewritten") {
  const std::string dir = fresh_dir("scan_cache_damaged");
  const std::string images = dir + "/images";
  const auto paths = sample_images(images);
  const std::string file = dir + "/cache/c.scans";
  handscs::ScanCounts counts;
  (void)handscs::scan_images(paths, {file}, images, &counts);
  const std::string good = handscs::read_file(file);
  // The format version follows the magic (19 bytes with its NUL); the checks' version follows that.
  std::string other_format = good, other_checks = good;
  other_format[19] ^= 1;
  other_checks[23] ^= 1;
  const std::vector<std::pair<std::string, std::string>> bad{
      {"garbage", "not a cache at all"},
      {"truncated", good.substr(0, good.size() - 3)},
      {"a flipped payload byte", good.substr(0, good.size() - 1) + char(good.back() ^ 0x20)},
      {"empty", ""},
      {"another format", other_format},
      {"another version of the checks", other_checks}};
  for (const auto& [what, bytes] : bad) {
    INFO(what);
    write_text(file, bytes);
    check_same(handscs::scan_images(paths, {file}, images, &counts), paths);
    CHECK(counts.scanned == paths.size());  // nothing trusted
    CHECK(handscs::read_file(file) == good);  // rewritten as before
  }
}

TEST_CASE("scan cache: entries of images not opened are kept; off writes nothing; fallback place") {
  const std::string dir = fresh_dir("scan_cache_keep");
  const std::string images = dir + "/images";
  const auto paths = sample_images(images);
  const std::vector<std::string> first(paths.begin(), paths.begin() + 2), rest(paths.begin() + 2, paths.end());
  // The first place cannot be created (its parent is a file): the second is written and read.
  write_text(dir + "/blocked", "a file where a folder would go");
  const std::vector<std::string> files{dir + "/blocked/c.scans", dir + "/cache/c.scans"};
  handscs::ScanCounts counts;
  (void)handscs::scan_images(first, files, images, &counts);
  (void)handscs::scan_images(rest, files, images, &counts);
  CHECK(fs::is_regular_file(files[1]));
  check_same(handscs::scan_images(paths, files, images, &counts), paths);
  CHECK(counts.cached == paths.size() - 1);  // both opens' images, all but the missing one

  // Every usable file is read: entries of the second place count while the first holds others (as
  // when a valid first file cannot be rewritten and new entries went to the second).
  const std::string other = dir + "/other/c.scans";
  (void)handscs::scan_images(first, {other}, images, &counts);  // the first two images only
  fs::remove(files[1]);
  (void)handscs::scan_images(rest, {files[1]}, images, &counts);  // the others only
  check_same(handscs::scan_images(paths, {other, files[1]}, images, &counts), paths);
  CHECK(counts.cached == paths.size() - 1);
}

TEST_CASE("scan cache: a read-only dataset folder is passed over, even by root") {
  const std::string dir = fresh_dir("scan_cache_read_only");
  const std::string images = dir + "/data/images";
  const auto paths = sample_images(images);
  // The dataset as unpacked read-only (r-x for all): root may still write there, the cache may not.
  fs::permissions(dir + "/data", fs::perms::owner_write | fs::perms::group_write | fs::perms::others_write,
                  fs::perm_options::remove);
  struct Restore {  // writable again however the test ends, so the clean-up can remove it
    std::string folder;
    ~Restore() {
      std::error_code ec;
      fs::permissions(folder, fs::perms::owner_write, fs::perm_options::add, ec);
    }
  } restore{dir + "/data"};
  const std::vector<std::string> files{dir + "/data/.handscs-cache/c.scans", dir + "/user/c.scans"};
  handscs::ScanCounts counts;
  (void)handscs::scan_images(paths, files, images, &counts);
  CHECK(fs::is_regular_file(files[1]));
  check_same(handscs::scan_images(paths, files, images, &counts), paths);
  CHECK(counts.cached == paths.size() - 1);  // all but the missing image, read from the user's place
  CHECK_FALSE(fs::exists(dir + "/data/.handscs-cache"));
}

TEST_CASE("scan cache: where the files go") {
  const std::string dir = fresh_dir("scan_cache_where");
  const auto files = handscs::scan_cache_files("auto", dir + "/images/train", 3);
  REQUIRE_FALSE(files.empty());
  CHECK(files[0] == dir + "/images/.handscs-cache/train.capture3.scans");
  const auto shared = handscs::scan_cache_files(dir + "/shared", dir + "/images/train", 3);
  REQUIRE(shared.size() == 1);
  CHECK(fs::path(shared[0]).parent_path() == fs::path(dir + "/shared"));
  CHECK(fs::path(shared[0]).filename().string().find("-train.capture3.scans") == 16);
  // Another dataset's folder of the same name gets another shared file.
  CHECK(handscs::scan_cache_files(dir + "/shared", dir + "/other/train", 3)[0] != shared[0]);
}

TEST_CASE("scan cache: a capture opened twice selects the same frames, the second time from the cache") {
  const std::string root = copy_of_tiny("scan_cache_capture");
  handscs::CaptureConfig config = tiny_config(root);
  config.annotation_cache = "off";
  const std::string images_dir = handscs::resolve_capture_layout(root, config.split).images_dir;
  const auto files = handscs::scan_cache_files(config.scan_cache, images_dir, config.capture);
  REQUIRE_FALSE(files.empty());
  fs::remove_all(fs::path(files[0]).parent_path());  // a cache the tiny capture's earlier opens wrote
  // One image black (skipped as such) and one cut short (a damaged JPEG).
  const auto frames = handscs::Capture::open(config).frames();
  REQUIRE(frames.size() > 2);
  write_jpeg(frames[0].image_path, cv::Mat(frames[0].camera.height, frames[0].camera.width, CV_8UC3,
                                           cv::Scalar(0, 0, 0)));
  const std::string bytes = handscs::read_file(frames[1].image_path);
  write_text(frames[1].image_path, bytes.substr(0, bytes.size() / 2));
  fs::remove_all(fs::path(files[0]).parent_path());

  const auto a = handscs::Capture::open(config);
  REQUIRE(fs::is_regular_file(files[0]));
  const auto written = fs::last_write_time(files[0]);
  const auto b = handscs::Capture::open(config);
  CHECK(fs::last_write_time(files[0]) == written);  // nothing new to store: every result was read
  REQUIRE(a.frames().size() == b.frames().size());
  CHECK(a.frames().size() == frames.size() - 2);
  for (size_t i = 0; i < a.frames().size(); ++i) CHECK(a.frames()[i].image_path == b.frames()[i].image_path);
  REQUIRE(a.skipped().size() == b.skipped().size());
  for (size_t i = 0; i < a.skipped().size(); ++i) CHECK(a.skipped()[i].reason == b.skipped()[i].reason);

  // "off": no file is written.
  fs::remove_all(fs::path(files[0]).parent_path());
  config.scan_cache = "off";
  const auto c = handscs::Capture::open(config);
  CHECK(c.frames().size() == a.frames().size());
  CHECK_FALSE(fs::exists(fs::path(files[0]).parent_path()));
}
