// Training configuration: loss weights, learning-rate groups and schedules, densification,
// inter-pose consistency, checkpoints, validation and NaN handling. Defaults follow the paper
// (§3.3) unless measured otherwise: docs/ABLATIONS.md#defaults-and-the-measurement-behind-each.
#pragma once

#include <cstdint>
#include <string>

namespace handscs {

struct LossWeights {
  double rgb = 1.0;           // L1 on RGB (paper: the unit term)
  double mask = 0.1;          // lambda_1, L2 between rendered alpha and mask
  double ssim = 0.01;         // lambda_2, 1 - SSIM ("3dgs" variant) on the ROI crop
  double lpips = 0.01;        // lambda_3, LPIPS on the ROI crop with eval.lpips (skipped without
                              // a weight file there)
  // LPIPS (a fixed cost per view) on every k-th step only, weighted k x lambda_3 there so the
  // objective's expectation is unchanged: 4 trains a third faster for the same PSNR.
  int64_t lpips_every = 4;
  // LPIPS on the crop area-averaged to this scale before the backbone; 1 = the crop as rendered
  // (the paper): half size saved little time and worsened evaluation LPIPS. The floor, 0.05, only
  // keeps a crop from shrinking to a few pixels.
  double lpips_scale = 1.0;
  // lambda_reg, offset regularisation L_reg: below the paper's 0.1, which keeps the geometry and
  // appearance decoders' offsets near zero here.
  double reg = 0.01;
  // L_reg's terms: "paper" = |dx| + |dSigma - I|_F + |dc| of the geometry and appearance decoders
  // (paper eq. for L_reg); "all" adds the fusion decoder's offsets (this code's choice before).
  enum class RegTerms { paper, all };
  RegTerms reg_terms = RegTerms::paper;
  // lambda_con, inter-pose consistency L_con, a mean over Gaussians (the paper's sum with 0.1 / N).
  double consistency = 0.1;
  // Penalty on the per-camera colour transforms' squared distance from the identity, summed over
  // cameras. Weak: it holds only what the images do not constrain (an affine matrix's cross terms).
  double camera_color = 1e-3;

  template <class V>
  void visit(V& v) {
    v.field("rgb", rgb, "weight of the L1 RGB loss", 0.0, 1e6);
    v.field("mask", mask, "weight of the L2 mask loss", 0.0, 1e6);
    v.field("ssim", ssim, "weight of 1 - SSIM", 0.0, 1e6);
    v.field("lpips", lpips, "weight of LPIPS (0 = never computed)", 0.0, 1e6);
    v.field("lpips_every", lpips_every,
            "LPIPS on steps whose number is a multiple of this, weighted this x lpips there", 1, 1e6);
    v.field("lpips_scale", lpips_scale,
            "LPIPS on the crop scaled by this (area average); 1 = full resolution", 0.05, 1.0);
    v.field("reg", reg, "weight of the offset regulariser L_reg", 0.0, 1e6);
    v.choice("reg_terms", reg_terms, {{"paper", RegTerms::paper}, {"all", RegTerms::all}},
             "L_reg terms: paper = geometry and appearance offsets; all = fusion offsets too");
    v.field("consistency", consistency, "weight of the inter-pose loss L_con (0 = off)", 0.0, 1e6);
    v.field("camera_color", camera_color,
            "weight of the penalty keeping the per-camera colour transforms near the identity", 0.0,
            1e6);
  }
};

struct LearningRates {
  double means = 1.6e-4;        // m per step at the start (3DGS, for a scene of ~1 m; a hand is 0.2 m)
  double means_final = 1.6e-6;  // reached at the last iteration (exponential decay, as 3DGS)
  double log_scales = 5e-3;
  double rotations = 1e-3;
  double colors = 2.5e-3;
  double opacity = 0.05;
  double embeddings = 1e-3;
  double networks = 1e-3;        // decoders and virtual-bone generator
  double networks_final = 1e-4;  // decayed exponentially like the means
  double gates = 1e-3;
  // Per-camera colour transforms (train.camera_color), constant: a 12% gain takes ~120 Adam steps,
  // few next to a run's thousands, and the jitter it leaves is far below the colour error removed.
  double camera_color = 1e-3;

  template <class V>
  void visit(V& v) {
    v.field("means", means, "initial learning rate of canonical means", 0.0, 1.0);
    v.field("means_final", means_final, "final learning rate of canonical means", 0.0, 1.0);
    v.field("log_scales", log_scales, "learning rate of log-scales", 0.0, 1.0);
    v.field("rotations", rotations, "learning rate of rotations", 0.0, 1.0);
    v.field("colors", colors, "learning rate of colours", 0.0, 1.0);
    v.field("opacity", opacity, "learning rate of opacity logits", 0.0, 10.0);
    v.field("embeddings", embeddings, "learning rate of e_g, e_a", 0.0, 1.0);
    v.field("networks", networks, "initial learning rate of decoders and generator", 0.0, 1.0);
    v.field("networks_final", networks_final, "final learning rate of the networks", 0.0, 1.0);
    v.field("gates", gates, "learning rate of the decoder gates", 0.0, 1.0);
    v.field("camera_color", camera_color, "learning rate of the per-camera colour transforms", 0.0,
            1.0);
  }
};

// 3DGS densification, on by default: past a few minutes of training it gives the best quality per
// time. Its threshold lets the built-in hand settle near 3k Gaussians, so a step stays cheap.
struct DensifyConfig {
  bool enabled = true;           // 3DGS clone/split/prune; off: the rig's vertex count is kept
  int64_t start = 300;           // first densification step (gradients need a few hundred steps)
  int64_t stop = 2500;           // last densification step: the default 3000 steps end with 500
                                 // that refine a fixed set (as configs/demo.json's 1500 of 2000)
  int64_t interval = 100;        // steps between densifications
  double grad_threshold = 1e-5;  // mean view-space gradient norm (pixels^-1) to densify (3DGS: 2e-4)
  double split_extent = 0.004;   // m: larger Gaussians split, smaller clone (a finger is ~1.6 cm wide)
  double min_opacity = 0.005;    // prune below (3DGS)
  int64_t max_gaussians = 10000; // hard cap on the count

  template <class V>
  void visit(V& v) {
    v.field("enabled", enabled, "densify and prune (3DGS style)");
    v.field("start", start, "first densification step", 0, 1e9);
    v.field("stop", stop, "last densification step", 0, 1e9);
    v.field("interval", interval, "steps between densifications", 1, 1e9);
    v.field("grad_threshold", grad_threshold, "view-space gradient threshold", 0.0, 1.0);
    v.field("split_extent", split_extent, "largest scale (m) above which Gaussians split", 0.0, 1.0);
    v.field("min_opacity", min_opacity, "prune Gaussians below this opacity", 0.0, 1.0);
    v.field("max_gaussians", max_gaussians, "maximum Gaussian count", 1, 1e8);
  }
};

struct ConsistencyConfig {
  // Correspondence search. "exact": the GEMM over all pairs (N^2 |P| work); "tree": the exact
  // k-d tree search (train/descriptor_tree.h), far cheaper at 10k+; "auto": exact GEMM while
  // N <= exact_max_gaussians, the tree above; "candidates": argmin over the K nearest canonical
  // neighbours only, approximate, kept to compare.
  enum class Search { automatic, exact, tree, candidates };
  Search search = Search::automatic;
  // auto: GEMM up to here, tree above. 0: the tree at every size, as it measured faster from 3k on.
  int64_t exact_max_gaussians = 0;
  int candidates = 32;                 // K of the candidate search
  int64_t refresh_every = 100;         // steps between recomputing the canonical K-NN candidates
  double delta = 1.3;                  // pose similarity bandwidth (paper)
  enum class Reduction { sum, mean };
  // sum: the paper's formula (a sum over i = 1..N_t); mean: the same with lambda_con divided by
  // N_t, the default, as the literal sum let L_con outweigh the image losses and cost PSNR.
  Reduction reduction = Reduction::mean;
  // "none": |M_i - M_pi(i)|^2 in raw units, where colours and embeddings outweigh positions (m) and
  // covariances (m^2); "groups": each group scale-free (train/consistency.h), which then dominates
  // the loss and costs PSNR.
  enum class Normalize { none, groups };
  Normalize normalize = Normalize::none;
  // Pose pairs whose weight w = exp(-|f_t - f_t-1|^2 / 2 delta^2) is below this skip L_con (search
  // and term): little weight, the dearest searches. 0 = every pair, as the paper.
  double min_weight = 0.05;

  template <class V>
  void visit(V& v) {
    v.choice("search", search,
             {{"auto", Search::automatic}, {"exact", Search::exact}, {"tree", Search::tree},
              {"candidates", Search::candidates}},
             "correspondence search: exact (GEMM), tree (exact k-d tree), auto = exact up to "
             "exact_max_gaussians then tree, candidates = K canonical neighbours (approximate)");
    v.field("exact_max_gaussians", exact_max_gaussians,
            "auto: largest Gaussian count searched by the GEMM (the tree above)", 0, 1e9);
    v.field("candidates", candidates, "K nearest canonical neighbours searched", 1, 4096);
    v.field("refresh_every", refresh_every, "steps between candidate refreshes", 1, 1e9);
    v.field("delta", delta, "pose similarity bandwidth delta", 1e-6, 1e6);
    v.choice("reduction", reduction, {{"sum", Reduction::sum}, {"mean", Reduction::mean}},
             "reduction over Gaussians");
    v.choice("normalize", normalize, {{"none", Normalize::none}, {"groups", Normalize::groups}},
             "attribute groups: none = raw squared differences; groups = each group scale-free");
    v.field("min_weight", min_weight,
            "skip L_con for pose pairs whose similarity weight is below this (0 = never)", 0.0, 1.0);
  }
};

// Training-pose refinement (train/pose_refine.h): a learned correction of each training pose's
// annotated pose and translation, beyond the paper (GauHuman and 3DGS-Avatar refine body poses).
// Off: the avatar absorbs the annotations' fit error before the corrections can.
struct PoseRefineConfig {
  bool enabled = false;
  // Adam step of the corrections (rad; translation in units of 0.1 m): enough to reach a ~3 degree
  // fit error within ten of the ~40 renders a pose gets in 2,000 steps of the demo.
  double lr = 5e-3;
  // Weight of reg |d|^2 (rad^2): weak, it holds near zero only what the images do not constrain.
  double reg = 1e-3;
  // First step that learns corrections: before it the avatar is far from the images and a pose
  // gradient says little about the pose (the corrections stay zero until then).
  int64_t start = 100;

  template <class V>
  void visit(V& v) {
    v.field("enabled", enabled, "learn a correction of each training pose (test poses never)");
    v.field("lr", lr, "Adam step of the corrections (rad; translation in 0.1 m)", 0.0, 1.0);
    v.field("reg", reg, "weight of the penalty: reg x the sum of squared corrections", 0.0, 1e6);
    v.field("start", start, "first step that learns the corrections", 0, 1e9);
  }
};

// Back-facing Gaussians skipped in training (beyond the paper; avatar/facing_cull.h): a Gaussian
// whose normal faces away from every camera of the step is neither decoded nor rasterised (L_reg,
// L_con take only decoded ones). Off: faster, but the skipped Gaussians do reach the image.
struct CullConfig {
  bool enabled = false;
  // Kept while cos(normal, view ray) <= max_cos: 0.3 keeps ~17 degrees past the silhouette.
  double max_cos = 0.3;

  template <class V>
  void visit(V& v) {
    v.field("enabled", enabled, "skip Gaussians facing away from the step's cameras");
    v.field("max_cos", max_cos, "kept while cos(normal, view ray) <= this (1 = keep all)", -1.0, 1.0);
  }
};

struct TrainConfig {
  int64_t iterations = 3000;        // optimisation steps
  int64_t seed = 0;                 // frame order, backgrounds
  // Views rendered per step by each process, their losses averaged; N data-parallel processes see
  // N x this per step. 1, as the paper.
  int64_t batch_size = 1;
  // Cameras of one pose each view renders, the pose decoded once for all of them (beyond the
  // paper). 1, as the paper: every frame on its own.
  int64_t views_per_pose = 1;
  enum class Background { black, white, random };
  Background background = Background::black;  // black, white or random (per step) in training
  double resolution_scale = 1.0;    // train on images scaled by this factor (0.5 = half size)
  int64_t checkpoint_every = 1000;  // steps between checkpoints (and one at the end)
  // Checkpoints kept in the run folder, newest first; 0 keeps every one (to score a run's
  // progress). 2: the newest, and the one before it if the newest is damaged.
  int64_t keep_checkpoints = 2;
  int64_t validate_every = 500;     // steps between validation renders (0 = never)
  int64_t log_every = 10;           // steps between metrics-log lines
  int64_t max_bad_steps = 5;        // consecutive NaN/Inf steps before a rollback
  double rollback_lr_factor = 0.5;  // learning rates are multiplied by this at each rollback
  LossWeights loss;
  LearningRates lr;
  DensifyConfig densify;
  ConsistencyConfig consistency;
  PoseRefineConfig pose_refine;
  CullConfig cull;
  // A colour transform per training camera (train/camera_color.h), learned with the avatar, as a
  // rig's cameras differ in exposure and white balance; evaluation applies it to a training camera,
  // the identity to any other. off: the paper; gain (default): a gain and a bias per channel;
  // affine: a 3x3 matrix and a bias. The measurement: docs/CAMERA_COLOR.md.
  enum class CameraColor { off, gain, affine };
  CameraColor camera_color = CameraColor::gain;

  template <class V>
  void visit(V& v) {
    v.field("iterations", iterations, "optimisation steps", 1, 1e9);
    v.field("seed", seed, "seed of frame order and backgrounds", 0, 9.0e15);
    v.field("batch_size", batch_size,
            "views per step on each process (their losses averaged; N processes see N x this)", 1, 4096);
    v.field("views_per_pose", views_per_pose,
            "cameras of one pose each view renders, decoding the pose once (1 = one frame each)", 1,
            4096);
    v.choice("background", background,
             {{"black", Background::black}, {"white", Background::white}, {"random", Background::random}},
             "training background");
    v.field("resolution_scale", resolution_scale, "image scale in training", 0.05, 1.0);
    v.field("checkpoint_every", checkpoint_every, "steps between checkpoints", 1, 1e9);
    v.field("keep_checkpoints", keep_checkpoints, "checkpoints kept, newest first (0 = all)", 0, 1e9);
    v.field("validate_every", validate_every, "steps between validation renders (0 = never)", 0, 1e9);
    v.field("log_every", log_every, "steps between metrics-log lines", 1, 1e9);
    v.field("max_bad_steps", max_bad_steps, "consecutive NaN/Inf steps before rollback", 1, 1e6);
    v.field("rollback_lr_factor", rollback_lr_factor, "learning-rate factor per rollback", 0.0, 1.0);
    v.section("loss", loss, "loss weights");
    v.section("lr", lr, "learning rates");
    v.section("densify", densify, "densification and pruning");
    v.section("consistency", consistency, "inter-pose consistency");
    v.section("pose_refine", pose_refine, "training-pose refinement (beyond the paper)");
    v.section("cull", cull, "back-facing Gaussians skipped in training (beyond the paper)");
    v.choice("camera_color", camera_color,
             {{"off", CameraColor::off}, {"gain", CameraColor::gain}, {"affine", CameraColor::affine}},
             "per-training-camera colour transform: off, gain (per channel gain and bias) or "
             "affine (3x3 and bias)");
  }
};

}  // namespace handscs
