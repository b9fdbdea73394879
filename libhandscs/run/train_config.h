// Training configuration: loss weights, learning-rate groups and schedules, densification,
// inter-pose consistency, checkpoints, validation and NaN handling. Defaults: paper §3.3 and
// DESIGN.md §4.
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
  // LPIPS on every k-th step only (its AlexNet forward + backward is a fixed cost per view),
  // weighted k x lambda_3 there so that the objective's expectation over steps is unchanged. 4 by
  // the rule fixed before configs/sweeps/lpips_every_real_2000.json ran (real_demo, 2,000 steps,
  // 3 seeds, paired against every step): PSNR -0.004 +- 0.013 dB, LPIPS +0.0015, training loop
  // 98.7 -> 63.9 s (k = 2 measured -0.075 dB; docs/BENCHMARKS.md, "LPIPS on a schedule").
  int64_t lpips_every = 4;
  // LPIPS on the crop scaled by this (area mode: adaptive average pooling, block means where the
  // scale divides the side) before the backbone: 0.5 runs AlexNet on a quarter of the pixels. 1 =
  // the crop as rendered (the paper; evaluation always scores the full image). 1 by the rule fixed
  // before configs/sweeps/lpips_scale_real.json ran: 0.5 worsened evaluation LPIPS on every seed
  // (mean +0.0091, PSNR -0.058 dB) for ~2.4 ms of a 35 ms step at 2,872 (docs/BENCHMARKS.md).
  // The lower bound of its range, 0.05, only keeps a crop from shrinking to a few pixels.
  double lpips_scale = 1.0;
  // lambda_reg, offset regularisation L_reg. The paper's 0.1 keeps the geometry and appearance
  // decoders' offsets near zero here; 1e-2 by the rule fixed before
  // configs/sweeps/reg_real_seeds3_7.json ran (real_demo, 2,000 steps, seeds 3-7, 500 held-out
  // images): +0.26 +- 0.13 dB paired over 0.1, better on every seed, LPIPS -0.0027
  // (docs/BENCHMARKS.md, "lambda_reg on five fresh seeds").
  double reg = 0.01;
  // L_reg's terms: "paper" = |dx| + |dSigma - I|_F + |dc| of the geometry and appearance decoders
  // (paper eq. for L_reg); "all" adds the fusion decoder's offsets (this code's choice before).
  enum class RegTerms { paper, all };
  RegTerms reg_terms = RegTerms::paper;
  // lambda_con, inter-pose consistency L_con (mean over Gaussians). 0.1 measured best of 1e-3,
  // 1e-2, 1e-1 and the paper's literal sum with 1e-2 (docs/BENCHMARKS.md, ablation on real_demo,
  // 400 steps, 3 seeds: +0.16 dB, SSIM +0.002, LPIPS -0.006 over 1e-2).
  double consistency = 0.1;
  // Weight of the per-camera colour transforms' penalty (train.camera_color): this x the sum over
  // training cameras of the squared distance of their parameters from the identity. Weak: a 10%
  // gain on one channel adds 1e-5 against an L1 RGB loss of ~0.02, so it only holds components the
  // images do not constrain (a dark camera's, an affine matrix's cross terms). Chosen before any
  // measurement.
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
  // Per-camera colour transforms (train.camera_color), constant: a 12% gain is ~120 steps of
  // Adam at this rate, small next to 2,000 steps, and its step-to-step jitter (~1e-3 of a gain)
  // is far below the colour error it removes. Chosen before any measurement.
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

// On by default: in the full sweep on `bench` (docs/BENCHMARKS.md, "Full sweep") every
// LPIPS front point beyond 1.5 minutes of training and every PSNR front point beyond 5 minutes is a
// densified run; threshold 1e-5 is the sweep's densify_5k and configs/demo.json's (N settles near
// 3k on the built-in hand, threshold-limited, so the step stays cheap).
struct DensifyConfig {
  bool enabled = true;           // 3DGS clone/split/prune; off: the rig's vertex count is kept
  int64_t start = 300;           // first densification step (gradients need a few hundred steps)
  int64_t stop = 2500;           // last densification step: the default 3000 steps end with 500
                                 // that refine a fixed set (as configs/demo.json's 1500 of 2000)
  int64_t interval = 100;        // steps between densifications
  double grad_threshold = 1e-5;  // mean view-space gradient norm (pixels^-1) to densify (3DGS: 2e-4,
                                 // not measured here; the sweep measured 1e-5 and 1e-6)
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
  // neighbours only, approximate (72.6% agreement at K = 32 on the demo avatar), kept to compare.
  enum class Search { automatic, exact, tree, candidates };
  Search search = Search::automatic;
  // auto: GEMM up to here, tree above. 0: the tree at every size, as it measured faster from 3k
  // Gaussians on (real_demo avatar, 2 threads: 15 / 142 / 645 ms at 3k / 10k / 20k against the
  // GEMM's 52 / 2304 / 9218 ms; docs/BENCHMARKS.md).
  int64_t exact_max_gaussians = 0;
  int candidates = 32;                 // K (DESIGN.md §4)
  int64_t refresh_every = 100;         // steps between recomputing the canonical K-NN candidates
  double delta = 1.3;                  // pose similarity bandwidth (paper)
  enum class Reduction { sum, mean };
  // sum: the paper's formula (a sum over i = 1..N_t); mean: the same with lambda_con divided by N_t
  // (~3,000 Gaussians here). Mean by measurement: at 2,000 steps on real_demo (3 seeds, paired
  // against no L_con) the literal sum at lambda_con 1e-2 loses 1.01 +- 0.17 dB, the mean at 1e-3 to
  // 1e-1 stays within 0.05 dB (docs/BENCHMARKS.md, "Ablation at 2,000 steps, the rest").
  Reduction reduction = Reduction::mean;
  // "none": |M_i - M_pi(i)|^2 in raw units, where positions (m) and covariances (m^2) differ by
  // 1e-6 and less, so colours and embeddings dominate; "groups": each group scale-free and
  // averaged (train/consistency.h), which then dominates the loss (97% of it at lambda_con 0.1)
  // and loses 1.77 +- 0.71 dB paired at 2,000 steps.
  enum class Normalize { none, groups };
  Normalize normalize = Normalize::none;
  // Pose pairs less similar than this skip L_con (search and term): its weight
  // w = exp(-|f_t - f_t-1|^2 / 2 delta^2) would scale the term below min_weight, and dissimilar pairs
  // are those whose exact search is dearest (~10x the distance evaluations of similar pairs).
  // 0 = every pair, as the paper. 0.05: on real_demo (400 steps, 3 seeds) 29.83 +- 0.13 dB against
  // every pair's 29.85 +- 0.17, while 65% of random training-pose pairs (4% of the weight mass)
  // skip the search (docs/BENCHMARKS.md, "Correspondence search").
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
// annotated pose and translation. Beyond the paper (GauHuman and 3DGS-Avatar refine body poses);
// off by default unless it measures better on the realistic capture (docs/BENCHMARKS.md).
struct PoseRefineConfig {
  bool enabled = false;
  // Adam step of the corrections (rad; translation in units of 0.1 m). A demo-capture pose is
  // rendered ~40 times in 2,000 steps: at 5e-3 a correction can reach the ~3 degrees of a
  // NeuralAnnot-like fit error within ten of them. Chosen before any measurement.
  double lr = 5e-3;
  // Weight of reg |d|^2 (rad^2): weak (3 degrees on all 48 components add 1.3e-4 to the loss), it
  // holds components the images do not constrain near zero.
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

// Back-facing Gaussians skipped in training (beyond the paper; avatar/facing_cull.h): a
// Gaussian whose rig-vertex normal, carried by its blend transform, faces away from every camera of
// the step is neither decoded nor rasterised; L_reg then averages over the decoded Gaussians and
// L_con takes only the pairs whose two Gaussians were decoded.
// Off: it takes a quarter off the forward + backward at 10k Gaussians but costs 0.11 dB of PSNR
// (3 seeds on real_demo, docs/BENCHMARKS.md), more than the 0.05 dB a default change needs.
struct CullConfig {
  bool enabled = false;
  // Kept while cos(normal, view ray) <= max_cos: 0.3 (~17 degrees past the silhouette), the value
  // the inference experiment chose (docs/BENCHMARKS.md), fixed before training was measured with it.
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
  // Views rendered per step by each process; their losses are averaged into one gradient. With N
  // data-parallel processes a step sees N x batch_size views (one process with batch_size N gives
  // the same steps). 1, as the paper: the step counts of every benchmark assume it.
  int64_t batch_size = 1;
  // Cameras of one pose each of those views becomes (beyond the paper): the pose is decoded once
  // and its Gaussians rasterised from up to this many of the pose's training cameras, so the
  // decoders' forward and backward serve them all (their losses averaged with the step's other
  // views). 1, as the paper: every frame on its own.
  int64_t views_per_pose = 1;
  enum class Background { black, white, random };
  Background background = Background::black;  // black, white or random (per step) in training
  double resolution_scale = 1.0;    // train on images scaled by this factor (0.5 = half size)
  int64_t checkpoint_every = 1000;  // steps between checkpoints (and one at the end)
  // Checkpoints kept in the run folder, newest first; 0 keeps every one (to score a run's progress,
  // e.g. tools/study/time_to_quality.sh). 2: the newest, and the one before it if the newest is damaged.
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
  // A colour transform per training camera (train/camera_color.h: exposure gain and white balance
  // differ between a rig's cameras), learned with the avatar and applied to its renders of that
  // camera; evaluation applies it to a training camera and the identity to any other. off: every
  // camera sees the avatar's own colours (the paper). gain: a gain and a bias per channel; affine:
  // a 3x3 matrix and a bias. Default gain: on real_demo it adds +0.83 dB over off (3 of 3 seeds)
  // and costs nothing measurable on a capture without camera response (docs/CAMERA_COLOR.md).
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
