// Model-mode evaluation (the paper's protocol): render every held-out frame of a capture with
// a trained avatar on the full image, composite the ground truth onto the same background with its
// mask, score PSNR/SSIM/LPIPS per image (and inside the capture's region masks, when it has them),
// and time the whole forward (LBS, SCS, decoders, rasterizer).
#pragma once

#include <string>

#include "metrics/eval_report.h"
#include "run/avatar_state_io.h"
#include "run/checkpoint.h"
#include "run/run_config.h"

namespace handscs {

struct ModelEvalOptions {
  std::string checkpoint;      // checkpoint file, or a run folder (its latest checkpoint)
  std::string out_dir;         // per_image.csv, summary.json, table.md, side_by_side/
  std::string split = "test";  // "test" (held out) or "train"
  bool side_by_side = false;   // write prediction | ground truth | error heat map PNGs
  int64_t max_images = 0;      // 0 = all; else this many, evenly spaced over the split
  std::string label;           // column-group label of table.md (default "<split>/Capture<c>")
  bool regions = true;         // score region masks (metrics/region_masks.h) when there are some
  std::string regions_dir;     // their folder: "" = <data.root>/regions when it holds regions.json
  // Score a capture other than the one the checkpoint trained on (data/capture_identity.h), with a
  // warning; refused otherwise.
  bool other_capture = false;
};

struct ModelEvalResult {
  EvalReport report;
  // train.camera_color: which colours were rendered ("the avatar's own colours for all N images"
  // or "per-camera transforms (gain) on N images of training cameras, the avatar's own colours on
  // M of cameras it never saw"); also summary.json's "camera_color" and a line under table.md.
  std::string camera_color;
  int64_t frames = 0;
  double forward_ms = 0;  // median per frame, whole forward
  double fps = 0;         // frames / total forward seconds
};

// Loads the checkpoint (its stored model config is authoritative), opens the capture of `config`
// and evaluates; writes the outputs into options.out_dir. With regions, every evaluated frame needs
// its mask <regions_dir>/<data.split>/<image path>.png: a missing one is an Error naming it (before
// anything is rendered); an unreadable or wrong-size one fails that frame.
ModelEvalResult evaluate_avatar(const RunConfig& config, const ModelEvalOptions& options);
// The same with the checkpoint already opened (open_trained_avatar); options.checkpoint is not read.
ModelEvalResult evaluate_avatar(const RunConfig& config, TrainedAvatar trained,
                                const ModelEvalOptions& options);

// The paper-style Markdown table: the capture's column group, then one per region (summary.regions),
// then FPS; with regions, a line under it gives each region's image count and pixel share.
std::string paper_table(const std::string& label, const EvalSummary& summary, double fps);

}  // namespace handscs
