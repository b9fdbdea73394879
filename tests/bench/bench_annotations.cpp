// handscs-bench-annotations: opening a capture inside InterHand2.6M's release-size annotation files.
// Generates, at run time (never committed), the tiny synthetic capture inside an annotation set
// inflated to --records image records the way the 5 fps train release is laid out: compact JSON,
// 80 cameras per capture, nine more captures of filler records before and after the tiny one,
// joint_3d and MANO_NeuralAnnot frames for each (about 0.55 kB per image record in data.json,
// 2.8 kB per joint_3d frame, 1.3 kB per MANO frame). Then opens the tiny capture in child
// processes (Capture::open, as handscs-train does first): once without the annotation cache
// (first open: it is built) and --repeats times with it. Prints one JSON object per record count:
// file sizes, generation time, open time and peak resident memory (kernel rusage of the child) of
// the first open and the median of the later ones. The files are in the page cache (just written):
// the first-open figure is parsing, not disk reading. With --pose-source joints the opened capture
// is read with data.pose_source=joints: its joint_3d entry is first inflated to as many frames as
// each filler capture holds (its own poses repeated with noise), so the first open fits a full
// capture's frames, as on the release.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>

#include "core/allocator.h"
#include "core/atomic_file.h"
#include "core/cli.h"
#include "core/config.h"
#include "core/installed_paths.h"
#include "core/logging.h"
#include "core/threads.h"
#include "data/capture.h"
#include "data/capture_layout.h"
#include "sweep/subprocess.h"
#include "synth/capture.h"
#include "bench_timing.h"

namespace {

using bench::Clock;
using bench::median;
using bench::ms_since;
using bench::seconds_since;

namespace fs = std::filesystem;
using json = nlohmann::json;

constexpr int kCameras = 80;          // cameras per capture in the release (varies 60-140)
constexpr int kFillerCaptures = 9;    // the measured set: the tiny capture and nine more
constexpr int64_t kFillerIdBase = 100000000;  // filler image ids start above any synthetic id
// Noise on the repeated joints of the inflated capture (mm per coordinate): 2.4 mm per joint on
// average, the residual the fit leaves on real InterHand2.6M joints (docs/FIT.md), so each repeat
// is a fresh fit of a realistic hand, not a copy of the last one.
constexpr double kRepeatNoiseMm = 1.5;

struct FileCloser {
  void operator()(std::FILE* f) const {
    if (f) std::fclose(f);
  }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

File open_for_writing(const std::string& path) {
  File file(std::fopen(path.c_str(), "wb"));
  if (!file) throw std::runtime_error(path + ": cannot write");
  std::setvbuf(file.get(), nullptr, _IOFBF, 1 << 20);
  return file;
}

// A float32 value printed the way the release prints them (shortest double of a float: ~17 digits).
void put_float(std::FILE* out, std::mt19937& rng, double lo, double hi) {
  const float value = std::uniform_real_distribution<float>(static_cast<float>(lo),
                                                            static_cast<float>(hi))(rng);
  std::fprintf(out, "%.17g", static_cast<double>(value));
}

struct FillerCapture {
  int capture;
  int64_t images;  // image records
  int64_t frames;  // frame indices (images / cameras, rounded up)
};

std::string filler_camera(int c) { return std::to_string(400002 + c); }

void write_filler_image(std::FILE* out, const FillerCapture& fc, int64_t i, int64_t id) {
  const int64_t frame = i / kCameras;
  const std::string cam = filler_camera(static_cast<int>(i % kCameras));
  std::fprintf(out,
               "{\"id\":%lld,\"file_name\":\"Capture%d/0390_dh_touchROM/cam%s/image%lld.jpg\","
               "\"width\":334,\"height\":512,\"capture\":%d,\"subject\":%d,\"seq_name\":"
               "\"0390_dh_touchROM\",\"camera\":\"%s\",\"frame_idx\":%lld}",
               (long long)id, fc.capture, cam.c_str(), (long long)frame, fc.capture, fc.capture,
               cam.c_str(), (long long)frame);
}

void write_filler_annotation(std::FILE* out, int64_t id, std::mt19937& rng) {
  std::fprintf(out, "{\"id\":%lld,\"image_id\":%lld,\"bbox\":[", (long long)id, (long long)id);
  for (int k = 0; k < 4; ++k) {
    if (k) std::fputc(',', out);
    put_float(out, rng, 20, 300);
  }
  std::fputs("],\"joint_valid\":[", out);
  for (int k = 0; k < 42; ++k) std::fputs(k ? ",[1]" : "[1]", out);
  std::fputs("],\"hand_type\":\"right\",\"hand_type_valid\":1}", out);
}

// data.json: filler captures before and after the tiny capture's own records, images then
// annotations (the release's order).
void write_data_json(const std::string& path, const json& tiny, const std::vector<FillerCapture>& fillers,
                     std::mt19937& rng) {
  File file = open_for_writing(path + ".tmp");
  std::FILE* out = file.get();
  const size_t half = fillers.size() / 2;
  bool first = true;
  auto separator = [&] {
    if (!first) std::fputc(',', out);
    first = false;
  };
  auto filler_range = [&](size_t from, size_t to, bool images) {
    int64_t id = kFillerIdBase;
    for (size_t f = 0; f < fillers.size(); ++f)
      for (int64_t i = 0; i < fillers[f].images; ++i, ++id) {
        if (f < from || f >= to) continue;
        separator();
        if (images)
          write_filler_image(out, fillers[f], i, id);
        else
          write_filler_annotation(out, id, rng);
      }
  };
  for (const char* key : {"images", "annotations"}) {
    const bool images = std::string(key) == "images";
    std::fprintf(out, "%s\"%s\":[", images ? "{" : ",", key);
    first = true;
    filler_range(0, half, images);
    for (const auto& entry : tiny.at(key)) {
      separator();
      std::fputs(entry.dump().c_str(), out);
    }
    filler_range(half, fillers.size(), images);
    std::fputc(']', out);
  }
  std::fputs("}", out);
  file.reset();
  fs::rename(path + ".tmp", path);
}

// {capture: {frame: value}} files (joint_3d, MANO): the tiny capture's entry and filler frames.
template <class WriteFrame>
void write_frames_json(const std::string& path, const json& tiny,
                       const std::vector<FillerCapture>& fillers, WriteFrame write_frame) {
  File file = open_for_writing(path + ".tmp");
  std::FILE* out = file.get();
  std::fputc('{', out);
  bool first_capture = true;
  for (auto it = tiny.begin(); it != tiny.end(); ++it) {
    std::fprintf(out, "%s\"%s\":%s", first_capture ? "" : ",", it.key().c_str(),
                 it.value().dump().c_str());
    first_capture = false;
  }
  for (const auto& fc : fillers) {
    std::fprintf(out, ",\"%d\":{", fc.capture);
    for (int64_t frame = 0; frame < fc.frames; ++frame) {
      std::fprintf(out, "%s\"%lld\":", frame ? "," : "", (long long)frame);
      write_frame(out);
    }
    std::fputc('}', out);
  }
  std::fputc('}', out);
  file.reset();
  fs::rename(path + ".tmp", path);
}

struct SetFiles {
  std::string root;
  double generate_s = 0;
  int64_t opened_joint_frames = 0;  // joint_3d frames of the capture that is opened
};

// The tiny capture's joint_3d entry grown to `frames` frames: its own frames, then copies of them in
// turn with Gaussian noise, numbered on from its last frame.
void inflate_joint_frames(json& tiny_joints, int64_t frames, std::mt19937& rng) {
  std::normal_distribution<double> noise(0.0, kRepeatNoiseMm);
  for (auto& [capture, entries] : tiny_joints.items()) {
    std::vector<json> own;
    int64_t next = 0;
    for (auto& [frame, entry] : entries.items()) {
      own.push_back(entry);
      next = std::max<int64_t>(next, std::stoll(frame) + 1);
    }
    for (size_t k = 0; static_cast<int64_t>(entries.size()) < frames; ++k, ++next) {
      json copy = own[k % own.size()];
      for (json& joint : copy["world_coord"])
        for (json& x : joint) x = x.get<double>() + noise(rng);
      entries[std::to_string(next)] = copy;
    }
  }
}

// The tiny capture at `root`, its annotation files inflated to `records` image records; with
// `full_joint_capture`, its joint_3d entry to a filler capture's frame count.
SetFiles generate_set(const std::string& root, int64_t records, bool full_joint_capture) {
  const auto start = Clock::now();
  fs::remove_all(root);
  handscs::write_synth_capture(handscs::make_synth_scene(handscs::synth_preset("tiny")), root);
  const handscs::CaptureLayout layout = handscs::resolve_capture_layout(root, "test");
  const json tiny_data = handscs::parse_json_file(layout.data_json);
  const json tiny_cameras = handscs::parse_json_file(layout.camera_json);
  json tiny_joints = handscs::parse_json_file(layout.joint_3d_json);
  const json tiny_mano = handscs::parse_json_file(layout.mano_json);
  int max_capture = 0;
  for (const auto& image : tiny_data.at("images")) max_capture = std::max(max_capture, image.at("capture").get<int>());

  const int64_t filler_images = std::max<int64_t>(0, records - static_cast<int64_t>(tiny_data.at("images").size()));
  std::vector<FillerCapture> fillers;
  for (int f = 0; f < kFillerCaptures; ++f) {
    FillerCapture fc;
    fc.capture = max_capture + 1 + f;
    fc.images = filler_images / kFillerCaptures + (f < filler_images % kFillerCaptures ? 1 : 0);
    fc.frames = (fc.images + kCameras - 1) / kCameras;
    fillers.push_back(fc);
  }
  std::mt19937 rng(12345);  // fixed: the same files on every run
  if (full_joint_capture) inflate_joint_frames(tiny_joints, fillers.front().frames, rng);
  write_data_json(layout.data_json, tiny_data, fillers, rng);

  write_frames_json(layout.joint_3d_json, tiny_joints, fillers, [&](std::FILE* out) {
    std::fputs("{\"world_coord\":[", out);
    for (int j = 0; j < 42; ++j) {
      std::fputs(j ? ",[" : "[", out);
      for (int k = 0; k < 3; ++k) {
        if (k) std::fputc(',', out);
        put_float(out, rng, k == 2 ? 900 : -150, k == 2 ? 1200 : 150);
      }
      std::fputc(']', out);
    }
    std::fputs("],\"joint_valid\":[", out);
    for (int j = 0; j < 42; ++j) std::fputs(j ? ",[1]" : "[1]", out);
    std::fputs("],\"hand_type\":\"right\",\"hand_type_valid\":true}", out);
  });
  write_frames_json(layout.mano_json, tiny_mano, fillers, [&](std::FILE* out) {
    std::fputs("{\"right\":{\"pose\":[", out);
    for (int k = 0; k < 48; ++k) {
      if (k) std::fputc(',', out);
      put_float(out, rng, -0.5, 0.5);
    }
    std::fputs("],\"shape\":[", out);
    for (int k = 0; k < 10; ++k) {
      if (k) std::fputc(',', out);
      put_float(out, rng, -1, 1);
    }
    std::fputs("],\"trans\":[", out);
    for (int k = 0; k < 3; ++k) {
      if (k) std::fputc(',', out);
      put_float(out, rng, -0.2, 0.2);
    }
    std::fputs("]},\"left\":null}", out);
  });

  json cameras = tiny_cameras;
  for (const auto& fc : fillers) {
    json entry = {{"campos", json::object()}, {"camrot", json::object()}, {"focal", json::object()},
                  {"princpt", json::object()}};
    for (int c = 0; c < kCameras; ++c) {
      const std::string id = filler_camera(c);
      entry["campos"][id] = {0.0, 0.0, -1000.0};
      entry["camrot"][id] = {{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {0.0, 0.0, 1.0}};
      entry["focal"][id] = {1200.0, 1200.0};
      entry["princpt"][id] = {167.0, 256.0};
    }
    cameras[std::to_string(fc.capture)] = entry;
  }
  handscs::write_file_atomic(layout.camera_json, cameras.dump());
  int64_t opened_joint_frames = 0;
  for (const auto& [capture, entries] : tiny_joints.items()) opened_joint_frames += entries.size();
  return {root, seconds_since(start), opened_joint_frames};
}

// Child mode: open the tiny capture once and print {"open_s", "images"} on stdout.
int open_once(const std::string& root, handscs::CaptureConfig::PoseSource pose_source) {
  handscs::CaptureConfig config;
  config.root = root;
  config.pose_source = pose_source;
  config.held_out_poses = 3;  // the tiny capture has 12 poses
  config.cache.prefetch_threads = 0;
  config.scan_cache = "off";  // the image checks at every open, as when this benchmark was first run
  const auto start = Clock::now();
  const handscs::Capture capture = handscs::Capture::open(config);
  const double seconds = seconds_since(start);
  std::cout << json{{"open_s", seconds}, {"images", capture.frames().size()}}.dump() << std::endl;
  return 0;
}

struct OpenResult {
  double open_s = 0, wall_s = 0, peak_mb = 0;
};

OpenResult run_open(const std::string& root, const std::string& pose_source, int threads, const std::string& log) {
  const auto result = handscs::run_process({handscs::executable_dir() + "/handscs-bench-annotations", "--open-once",
                                            root, "--pose-source", pose_source, "--threads", std::to_string(threads)},
                                           log);
  if (result.exit_code != 0)
    throw std::runtime_error("the opening child failed (exit " + std::to_string(result.exit_code) +
                             "); see " + log);
  std::ifstream in(log);
  std::string line, last_json;
  while (std::getline(in, line))
    if (!line.empty() && line[0] == '{') last_json = line;
  const json reported = json::parse(last_json);
  return {reported.at("open_s").get<double>(), result.wall_seconds, result.peak_rss_mb};
}

double file_mb(const std::string& path) { return fs::file_size(path) / 1e6; }

}  // namespace

int main(int argc, char** argv) {
  handscs::log_to_stderr();  // stdout carries the JSON only
  handscs::keep_freed_memory_for_reuse();  // as the tools run (core/allocator.h)
  CLI::App app{
      "handscs-bench-annotations: opening a capture inside release-size InterHand2.6M annotation\n"
      "files (generated at run time), without and with the annotation cache. One JSON object per\n"
      "record count on stdout."};
  std::vector<int64_t> records{1400000};
  std::string work = (fs::temp_directory_path() / "handscs_bench_annotations").string();
  std::string open_root;
  int repeats = 3;
  int threads = 2;
  std::string pose_source = "mano";
  bool keep = false;
  app.add_option("--records", records,
                 "image records in data.json (the 5 fps train split ~1.4M, the 30 fps ~2.6M)")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--work", work, "folder for the generated sets (removed afterwards)")
      ->capture_default_str();
  app.add_option("--repeats", repeats, "cached opens timed (median)")->capture_default_str();
  app.add_flag("--keep", keep, "keep the generated sets");
  app.add_option("--pose-source", pose_source,
                 "data.pose_source of the open: mano, or joints (the opened capture then holds as many joint frames "
                 "as each other capture, and its first open fits them)")
      ->check(CLI::IsMember({"mano", "joints"}))
      ->capture_default_str();
  app.add_option("--threads", threads, "threads of the opening process (the fit's)")->capture_default_str();
  app.add_option("--open-once", open_root, "(internal) open the capture at this root once");
  CLI11_PARSE(app, argc, argv);
  try {
    const auto source = handscs::choice_value(pose_source, handscs::CaptureConfig::pose_source_names());
    handscs::set_threads(threads);
    if (!open_root.empty()) return open_once(open_root, source);
    for (const int64_t n : records) {
      const std::string root = (fs::path(work) / ("records_" + std::to_string(n))).string();
      spdlog::info("generating {} image records in {}", n, root);
      const SetFiles set = generate_set(root, n, source == handscs::CaptureConfig::PoseSource::joints);
      const handscs::CaptureLayout layout = handscs::resolve_capture_layout(root, "test");
      const std::string log = root + "/open.log";  // the later opens'; the first open's is kept apart (--keep)
      const OpenResult first = run_open(root, pose_source, threads, root + "/first_open.log");
      std::vector<double> open_s, wall_s, peak_mb;
      for (int r = 0; r < repeats; ++r) {
        const OpenResult again = run_open(root, pose_source, threads, log);
        open_s.push_back(again.open_s);
        wall_s.push_back(again.wall_s);
        peak_mb.push_back(again.peak_mb);
      }
      double cache_mb = 0;
      const std::string cache_dir = fs::path(layout.data_json).parent_path() / ".handscs-cache";
      for (const auto& entry : fs::directory_iterator(cache_dir)) cache_mb += fs::file_size(entry) / 1e6;
      json out = {{"records", n},
                  {"pose_source", pose_source},
                  {"opened_capture_joint_frames", set.opened_joint_frames},
                  {"threads", threads},
                  {"data_json_mb", file_mb(layout.data_json)},
                  {"joint_3d_mb", file_mb(layout.joint_3d_json)},
                  {"mano_mb", file_mb(layout.mano_json)},
                  {"camera_json_mb", file_mb(layout.camera_json)},
                  {"generate_s", set.generate_s},
                  {"first_open_s", first.open_s},
                  {"first_open_wall_s", first.wall_s},
                  {"first_open_peak_rss_mb", first.peak_mb},
                  {"cached_open_s_median", median(open_s)},
                  {"cached_open_wall_s_median", median(wall_s)},
                  {"cached_open_peak_rss_mb_median", median(peak_mb)},
                  {"cache_mb", cache_mb},
                  {"repeats", repeats}};
      std::cout << out.dump() << std::endl;
      if (!keep) fs::remove_all(root);
    }
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
