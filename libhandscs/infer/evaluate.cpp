#include "infer/evaluate.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <set>

#include <spdlog/spdlog.h>
#include <torch/types.h>

#include "avatar/avatar.h"
#include "infer/posed_hands.h"
#include "core/atomic_file.h"
#include "core/config.h"
#include "core/error.h"
#include "core/progress.h"
#include "core/text.h"
#include "data/capture.h"
#include "data/capture_identity.h"
#include "io/png.h"
#include "metrics/comparison_panel.h"
#include "metrics/image_scorer.h"
#include "metrics/image_tensor.h"
#include "metrics/region_masks.h"
#include "run/avatar_state_io.h"
#include "run/camera_color_transform.h"

namespace handscs {

namespace {
// Prediction | ground truth | error heat map (metrics/comparison_panel.h), titled with the image,
// its camera and its scores.
cv::Mat side_by_side(const torch::Tensor& pred, const torch::Tensor& gt, const FrameInfo& frame,
                     const ImageScores& scores) {
  char text[160];
  std::snprintf(text, sizeof(text), "%s  camera %s  PSNR %.2f dB  SSIM %.4f%s",
                frame.file_name.c_str(), frame.camera_id.c_str(), scores.psnr, scores.ssim,
                scores.lpips ? ("  LPIPS " + score_text(scores.lpips, 4)).c_str() : "");
  return comparison_panel(pred, gt, text);
}

// Scores over a capture with damaged JPEGs would silently cover fewer images than the protocol
// asks: training skips them, evaluation refuses.
void refuse_damaged_images(const Capture& capture) {
  std::vector<std::string> damaged;
  for (const auto& skipped : capture.skipped())
    if (skipped.reason == "damaged JPEG") damaged.push_back(skipped.path);
  if (damaged.empty()) return;
  throw Error(std::to_string(damaged.size()) + " damaged JPEG(s) in the capture (first: " + damaged.front() +
              "; the warnings above say what is wrong with each): repair or remove them before scoring");
}

// The split's keys match any capture of the same layout: a data.root naming another capture (or
// this one with frames gone) would be scored as the run's own test images.
void check_capture_identity(const TrainedAvatar& trained, const Capture& capture, const std::string& root,
                            bool other_capture) {
  if (!trained.capture_identity) {
    spdlog::info("{} was written by a build that did not record its capture: {} is taken to be it",
                 trained.path, root);
    return;
  }
  // Without the run's validation cameras the test cameras open too: the run's frames are then the
  // training ones (the validation cameras back among them).
  const bool validation_cameras_dropped =
      !trained.trained_config.data.validation_cameras.empty() && capture.config().validation_cameras.empty();
  const auto differences = identity_differences(
      *trained.capture_identity,
      capture_identity(capture, validation_cameras_dropped ? capture.train() : capture.frames()));
  if (differences.empty()) return;
  const std::string text = "the frames " + root + " gives differ from those " + trained.path + " trained on (" +
                           join(differences, "; ") + "): another capture, or a data setting that selects "
                           "other frames";
  if (!other_capture)
    throw Error(text + ".\nIts scores would not be the run's: evaluate on the run's capture, or pass "
                       "--other-capture to score these frames anyway");
  spdlog::warn("{}: scoring it as asked (--other-capture)", text);
}
}  // namespace

std::string paper_table(const std::string& label, const EvalSummary& s, double fps) {
  std::string header = "| Method | " + label + " PSNR ↑ | SSIM ↑ | LPIPS ↓ |";
  std::string rule = "|---|---|---|---|";
  std::string row = "| HandSCS (this run) | " + score_text(s.psnr, 2) + " | " +
                    score_text(s.ssim, 3) + " | " + score_text(s.lpips, 4) + " |";
  std::string notes;
  for (const auto& region : s.regions) {
    header += " " + region.name + " PSNR ↑ | SSIM ↑ | LPIPS ↓ |";
    rule += "---|---|---|";
    row += " " + score_text(region.psnr_pooled, 2) + " | " + score_text(region.ssim, 3) + " | " +
           score_text(region.lpips, 4) + " |";
    char share[32];
    std::snprintf(share, sizeof(share), "%.2f%%", 100 * region.pixel_fraction);
    notes += std::string(notes.empty() ? "" : "; ") + region.name + " in " +
             std::to_string(region.images) + " of " + std::to_string(s.num_scored) + " images, " +
             share + " of the pixels";
  }
  char fps_text[32];
  std::snprintf(fps_text, sizeof(fps_text), "%.1f", fps);
  std::string t = header + " FPS (CPU) |\n" + rule + "---|\n" + row + " " + fps_text + " |\n";
  if (!notes.empty())
    t += "\nRegion columns: over the images where the region has pixels, the PSNR of their pooled MSE "
         "(one exact match makes a mean of per-image PSNRs infinite) and the SSIM and LPIPS means (" +
         notes + ").\n";
  return t;
}

ModelEvalResult evaluate_avatar(const RunConfig& config, const ModelEvalOptions& options) {
  return evaluate_avatar(config, open_trained_avatar(options.checkpoint), options);
}

ModelEvalResult evaluate_avatar(const RunConfig& config_in, TrainedAvatar trained,
                                const ModelEvalOptions& options) {
  const std::string& ckpt_path = trained.path;
  RunConfig config = config_in;
  // The architecture comes from the checkpoint; data and evaluation settings from the caller.
  RunConfig& stored = trained.config;
  const auto differences = json_differences(config_to_json(stored.model), config_to_json(config.model), "model");
  if (!differences.empty())
    spdlog::warn("the given config's model section differs from the checkpoint's ({}); the checkpoint's is used",
                 join(differences, "; "));
  config.model = stored.model;
  config.data.rig = stored.data.rig;
  if (config.data.hand != stored.data.hand)
    spdlog::warn("data.hand = {} but the checkpoint's avatar was trained with data.hand = {}: "
                 "evaluating {}", hand_name(config.data.hand), hand_name(stored.data.hand),
                 stored.data.hand == CaptureConfig::Hands::both ? "both hands"
                                                                : "the " + hand_name(stored.data.hand) + " hand");
  config.data.hand = stored.data.hand;
  config.data.flat_hand_mean = stored.data.flat_hand_mean;

  ensure_directory(options.out_dir);
  // Masks are cached beside the run the checkpoint came from when there is one.
  const auto run_dir = std::filesystem::path(ckpt_path).parent_path().parent_path();
  const std::string cache = std::filesystem::exists(run_dir / "config.json")
                                ? (run_dir / "cache").string()
                                : options.out_dir + "/cache";
  Capture capture = Capture::open(config.data, cache);
  refuse_damaged_images(capture);
  check_capture_identity(trained, capture, config.data.root, options.other_capture);
  ImageScorer scorer(config.eval);
  RegionLegend legend;
  std::string regions_dir;
  if (options.regions) {
    regions_dir = options.regions_dir.empty() ? (std::filesystem::path(config.data.root) / "regions").string()
                                              : options.regions_dir;
    const std::string legend_path = (std::filesystem::path(regions_dir) / kRegionLegendFile).string();
    // Without --regions a capture without region masks is evaluated as before.
    if (!options.regions_dir.empty() || std::filesystem::exists(legend_path))
      legend = read_region_legend(legend_path);
  }
  if (!scorer.has_lpips()) spdlog::warn("LPIPS skipped: {}", scorer.lpips_skip_reason());

  std::vector<FrameInfo> frames = options.split == "train" ? capture.train() : capture.test();
  require(!frames.empty(), "evaluation: the capture has no " + options.split + " frames");
  if (options.max_images > 0 && static_cast<int64_t>(frames.size()) > options.max_images) {
    // Evenly spaced over the split, so a subset still covers every pose range and camera.
    std::vector<FrameInfo> subset;
    const size_t total = frames.size(), wanted = static_cast<size_t>(options.max_images);
    for (size_t k = 0; k < wanted; ++k) subset.push_back(frames[k * total / wanted]);
    frames = std::move(subset);
  }

  const std::string masks_dir =
      (std::filesystem::path(regions_dir) / capture.region_subfolder()).lexically_normal().string();
  if (!legend.empty()) {
    // Every mask must be there before hours of rendering start.
    int64_t missing = 0;
    std::string first_missing;
    for (const auto& frame : frames) {
      const std::string path = region_mask_path(masks_dir, frame.file_name);
      if (std::filesystem::exists(path)) continue;
      if (missing++ == 0) first_missing = path;
    }
    require(missing == 0, first_missing + ": region mask not found (" + std::to_string(missing) + " of " +
                              std::to_string(frames.size()) + " frames have none under " + masks_dir +
                              "; --no-regions evaluates without regions)");
  }

  ModelEvalResult result;
  result.report.mode = "model";
  result.report.inputs = {{"checkpoint", ckpt_path},
                          {"capture_root", config.data.root},
                          {"layout", layout_name(capture.layout())},
                          {"split", config.data.split},
                          {"capture", config.data.capture},
                          {"frames", options.split}};
  result.report.config = config_to_json(config.eval);
  result.report.lpips_skip_reason = scorer.has_lpips() ? "" : scorer.lpips_skip_reason();
  result.report.inputs["regions"] = legend.empty() ? json(nullptr) : json(legend.path);
  result.report.regions = legend.regions;
  if (options.side_by_side) ensure_directory(options.out_dir + "/side_by_side");

  const auto& bg = config.eval.background;
  const auto bg_tensor = torch::tensor({float(bg[0]), float(bg[1]), float(bg[2])});
  RasterSettings settings;
  settings.background = {float(bg[0]), float(bg[1]), float(bg[2])};
  // train.camera_color: a training camera's images get its transform, any other camera's the
  // avatar's own colours (the transforms' mean is the identity), which is what a novel view gets.
  const CameraColorTable& colors = trained.colors;
  int64_t transformed = 0, own_colors = 0;
  std::set<std::string> transformed_cameras, own_color_cameras;
  std::vector<double> forward_ms;
  ProgressBar bar("eval", static_cast<int64_t>(frames.size()));
  c10::InferenceMode guard;
  PosedHands hands(trained);
  for (size_t i = 0; i < frames.size(); ++i) {
    const auto& frame = frames[i];
    if (i + 1 < frames.size()) capture.prefetch({frames[i + 1].index}, true);
    EvalEntry entry;
    entry.name = frame.file_name;
    entry.sources = {{"image", frame.image_path}, {"camera", frame.camera_id}};
    try {
      FrameSample sample = capture.load(frame, /*full_image=*/true);
      entry.width = sample.image.size(1);
      entry.height = sample.image.size(0);
      torch::Tensor regions;
      if (!legend.empty()) {
        const std::string path = region_mask_path(masks_dir, frame.file_name);
        entry.sources["regions"] = path;
        regions = region_planes(load_region_mask(path, entry.width, entry.height), legend);
      }
      const auto mask = sample.mask.to(torch::kFloat32).unsqueeze(2);
      const auto gt = sample.image.to(torch::kFloat32).div(255.0) * mask + bg_tensor * (1 - mask);
      // Posed once per pose (PoseMemo); the reported forward time of every image is its pose's
      // full cost plus its own rasterisation, as if each were rendered alone.
      const auto& posed = hands.pose(frame, frame.image_path);
      const auto t0 = std::chrono::steady_clock::now();
      const RasterOutput render = render_posed(posed, sample.camera, settings);
      forward_ms.push_back(hands.pose_ms() + std::chrono::duration<double, std::milli>(
                                                std::chrono::steady_clock::now() - t0).count());
      const auto transform = colors.find(frame.camera_id);
      entry.sources["camera_color"] = transform ? camera_color_name(colors.mode) : "identity";
      (transform ? transformed : own_colors) += 1;
      (transform ? transformed_cameras : own_color_cameras).insert(frame.camera_id);
      const auto pred =
          (transform ? apply_color_transform(render.rgb, render.alpha, settings.background, *transform)
                     : render.rgb)
              .clamp(0, 1);
      entry.scores = scorer.score(pred, gt, {}, regions);
      entry.ok = true;
      if (options.side_by_side) {
        std::string name = frame.file_name;
        std::replace(name.begin(), name.end(), '/', '_');
        name = name.substr(0, name.rfind('.')) + ".png";
        write_png(options.out_dir + "/side_by_side/" + name,
                  side_by_side(pred, gt, frame, entry.scores));
      }
    } catch (const Error& e) {
      entry.ok = false;
      entry.error = e.what();
    }
    result.report.entries.push_back(std::move(entry));
    bar.update(static_cast<int64_t>(i + 1));
  }
  bar.finish();
  spdlog::info("eval: {} images, {} hand poses computed (each once)", frames.size(), hands.computed());

  result.frames = static_cast<int64_t>(forward_ms.size());
  if (!forward_ms.empty()) {
    double total = 0;
    for (double ms : forward_ms) total += ms;
    result.fps = forward_ms.size() / (total / 1000.0);
    std::sort(forward_ms.begin(), forward_ms.end());
    result.forward_ms = forward_ms[forward_ms.size() / 2];
  }
  const auto summary = result.report.summary();
  auto json = eval_report_to_json(result.report);
  const std::string mode = camera_color_name(colors.mode);
  if (colors.matrices.empty())
    result.camera_color = "the avatar's own colours on all " + std::to_string(own_colors) +
                          " images (the checkpoint has no per-camera colour transforms)";
  else
    result.camera_color = "per-camera colour transforms (" + mode + ") on " +
                          std::to_string(transformed) + " images of " +
                          std::to_string(transformed_cameras.size()) + " training cameras; the " +
                          "avatar's own colours on " + std::to_string(own_colors) + " images of " +
                          std::to_string(own_color_cameras.size()) + " cameras it never saw";
  json["camera_color"] = {{"mode", mode},
                          {"transformed_images", transformed},
                          {"identity_images", own_colors},
                          {"transformed_cameras", transformed_cameras},
                          {"identity_cameras", own_color_cameras},
                          {"note", result.camera_color}};
  json["rendering"] = {{"frames", result.frames},
                       {"forward_ms_median", result.forward_ms},
                       {"fps", result.fps},
                       {"gaussians", trained.gaussian_count()},
                       {"width", frames.front().camera.width},
                       {"height", frames.front().camera.height}};
  write_file_atomic(options.out_dir + "/summary.json", json.dump(2) + "\n");
  write_file_atomic(options.out_dir + "/per_image.csv", eval_report_to_csv(result.report));
  // The table's label: InterHand2.6M's split and capture, or the other layouts' capture folder.
  const std::filesystem::path root = std::filesystem::path(config.data.root).lexically_normal();
  const std::string label =
      !options.label.empty()             ? options.label
      : capture.layout() == CaptureConfig::Layout::interhand ? config.data.split + "/Capture" + std::to_string(config.data.capture)
      : (root.has_filename() ? root.filename() : root.parent_path().filename()).string();
  write_file_atomic(options.out_dir + "/table.md", paper_table(label, summary, result.fps) +
                                                      "\nColours: " + result.camera_color + ".\n");
  return result;
}

}  // namespace handscs
