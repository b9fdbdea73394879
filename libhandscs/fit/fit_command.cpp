#include "fit/fit_command.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <spdlog/spdlog.h>

#include "core/atomic_file.h"
#include "core/config.h"
#include "data/capture_json.h"
#include "data/handscs_capture.h"
#include "fit/fitted_capture.h"
#include "fit/keypoint_file.h"
#include "fit/multiview_capture.h"
#include "fit/overlay.h"
#include "fit/triangulation.h"
#include "hand/joint_order.h"
#include "hand/lbs_one_pose.h"
#include "io/png.h"

namespace handscs {

namespace fs = std::filesystem;

namespace {

constexpr const char* kSides[2] = {"right", "left"};
// Frames of a sequence on which the other hand's rig is tried as well (evenly spaced): enough to
// tell a swapped hand, a fraction of the fit's time on a long capture.
constexpr int kHandednessSamples = 10;
// The other hand's rig must fit this much better (mean residual ratio) to call the hand swapped:
// a true hand fits its rig to ~1-5 mm, its mirror image bends fingers backwards (10+ mm).
constexpr double kSwappedRatio = 0.5;
// Views drawn when none are named: this many, evenly spread over the capture.
constexpr int kDefaultOverlayViews = 4;
constexpr int kOverlayMarginPx = 40;

struct SideInput {
  std::vector<std::string> names;    // frame names
  std::vector<HandKeypoints> frames;
};

struct SideResult {
  std::vector<std::string> names;
  std::vector<HandFit> fits;
  std::vector<std::string> skip_reason;  // "" when fitted
  std::vector<HandKeypoints> keypoints;   // what was fitted
  double ms_per_frame = 0;
};

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return std::nan("");
  std::sort(values.begin(), values.end());
  const double at = q * (values.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(at)), hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (values[hi] - values[lo]) * (at - lo);
}

// The file that marks a folder as a fit's (what --overwrite may replace).
constexpr const char* kFitMarker = "fit_config.json";

// Checks --out before any work; returns the staging folder the fit will be written into (beside
// --out, so the final rename stays on one file system): --out is replaced only once the whole fit
// is written.
std::string check_output(const FitCommandOptions& o) {
  if (o.out.empty()) throw Error("--out: name the folder to write the fit into");
  if (fs::exists(o.out) && !fs::is_directory(o.out)) throw Error(o.out + ": is a file, not a folder (--out)");
  if (fs::exists(o.out) && !fs::is_empty(o.out)) {
    if (!o.overwrite)
      throw Error(o.out + ": not empty; pass --overwrite to replace the fit in it, or name a new folder");
    if (!fs::exists(fs::path(o.out) / kFitMarker))
      throw Error(o.out + ": holds no fit (no " + kFitMarker +
                  "); --overwrite replaces only a folder handscs-fit wrote: name a new folder");
  }
  const fs::path out = fs::absolute(o.out).lexically_normal();
  return (out.parent_path() / ("." + out.filename().string() + ".partial")).string();
}

// Puts the written fit in place of --out (the earlier fit, if any, goes only then).
void finish_output(const FitCommandOptions& o, const std::string& stage) {
  const std::string replaced = stage + ".replaced";
  fs::remove_all(replaced);
  if (fs::exists(o.out)) fs::rename(o.out, replaced);
  fs::rename(stage, o.out);
  fs::remove_all(replaced);
}

// Mean residual of a fit with the given model, over up to kHandednessSamples frames.
double sampled_mean(const JointModel& model, const SideInput& input, const KeypointFitConfig& config) {
  const size_t n = input.frames.size();
  const size_t samples = std::min<size_t>(n, kHandednessSamples);
  double sum = 0;
  int count = 0;
  for (size_t s = 0; s < samples; ++s) {
    const HandKeypoints& k = input.frames[s * n / samples];
    if (k.num_valid() < kMinFitKeypoints) continue;
    sum += fit_keypoints(model, k, config).mean_mm;
    ++count;
  }
  return count ? sum / count : std::nan("");
}

SideResult fit_side(const JointModel& model, const JointModel& other, const SideInput& input,
                    const FitCommandConfig& config, const std::string& side, bool check_handedness) {
  SideResult result;
  result.names = input.names;
  result.keypoints = input.frames;
  if (input.frames.empty()) return result;
  if (check_handedness) {
    const double own = sampled_mean(model, input, config.fit);
    const double mirrored = sampled_mean(other, input, config.fit);
    if (mirrored < kSwappedRatio * own)
      throw Error("the " + side + " hand's keypoints fit the other hand's rig far better (mean " +
                  std::to_string(mirrored) + " mm against " + std::to_string(own) + " mm on up to " +
                  std::to_string(kHandednessSamples) +
                  " frames): the hands are swapped, or the keypoint order or handedness is wrong");
  }
  const auto start = std::chrono::steady_clock::now();
  result.fits = fit_keypoint_sequence(model, input.frames, config.fit, "fit " + side + " hand");
  result.ms_per_frame = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count() /
                        static_cast<double>(input.frames.size());
  result.skip_reason.resize(input.frames.size());
  for (size_t f = 0; f < input.frames.size(); ++f) {
    const HandFit& fit = result.fits[f];
    if (!fit.fitted)
      result.skip_reason[f] = "too few keypoints (" + std::to_string(input.frames[f].num_valid()) + " of 21)";
    else if (fit.mean_mm > config.poor_fit_mm)
      result.skip_reason[f] = fmt::format(
          "poor fit (mean residual {:.2f} mm > poor_fit_mm {:g}): a wrong joint order, swapped hands or "
          "mislabelled joints",
          fit.mean_mm, config.poor_fit_mm);
  }
  return result;
}

json poses_json(const JointModel& model, const SideResult& r, bool flat) {
  json poses = json::array();
  for (size_t f = 0; f < r.fits.size(); ++f) {
    if (!r.skip_reason[f].empty()) continue;
    const auto pose = rig_pose(model, r.fits[f].params, flat);
    poses.push_back({{"name", r.names[f]},
                     {"pose", number_array(pose.data(), kPoseDim)},
                     {"shape", number_array(r.fits[f].params.shape.data(), kShapeDim)},
                     {"trans", number_array(r.fits[f].params.trans.data(), 3)}});
  }
  return {{"poses", poses}};
}

// Per-finger mean residual (mm) over a side's fitted frames: the finger's three joints and tip.
std::map<std::string, double> finger_means(const SideResult& r) {
  std::map<std::string, double> out;
  for (int f = 0; f < kFingers; ++f) {
    double sum = 0;
    int n = 0;
    for (size_t i = 0; i < r.fits.size(); ++i) {
      if (!r.skip_reason[i].empty()) continue;
      for (int j : {kFingerJoints[f][0], kFingerJoints[f][1], kFingerJoints[f][2], kTipJoint0 + f})
        if (!std::isnan(r.fits[i].residual_mm[j])) {
          sum += r.fits[i].residual_mm[j];
          ++n;
        }
    }
    out[kFingerNames[f]] = n ? sum / n : std::nan("");
  }
  return out;
}

// How the fitted rig's bone lengths differ from the keypoints' (mm, fitted minus keypoints) over a
// side's fitted frames, for bones with both keypoints: whether the rig's shape matches the person.
json bone_length_summary(const SideResult& r) {
  std::array<double, kFingers> sum{}, sum_abs{};
  std::array<int, kFingers> count{};
  double max_abs = 0;
  for (size_t i = 0; i < r.fits.size(); ++i) {
    if (!r.skip_reason[i].empty()) continue;
    const HandKeypoints& k = r.keypoints[i];
    for (int j = 1; j < 21; ++j) {
      const int p = mano21_parent(j);
      if (!k.valid[j] || !k.valid[p]) continue;
      auto length = [&](const std::array<double, 63>& x) {
        return std::hypot(x[3 * j] - x[3 * p], x[3 * j + 1] - x[3 * p + 1], x[3 * j + 2] - x[3 * p + 2]);
      };
      const double error = 1e3 * (length(r.fits[i].joints) - length(k.joints));
      const int finger = mano21_finger(j);
      sum[finger] += error;
      sum_abs[finger] += std::fabs(error);
      ++count[finger];
      max_abs = std::max(max_abs, std::fabs(error));
    }
  }
  double total = 0, total_abs = 0;
  int n = 0;
  json per_finger = json::object();
  for (int f = 0; f < kFingers; ++f) {
    total += sum[f];
    total_abs += sum_abs[f];
    n += count[f];
    per_finger[kFingerNames[f]] = count[f] ? json(sum[f] / count[f]) : json(nullptr);
  }
  if (!n) return nullptr;
  return {{"mean_mm", total / n}, {"mean_abs_mm", total_abs / n}, {"max_abs_mm", max_abs},
          {"per_finger_mean_mm", per_finger}};
}

json side_summary(const SideResult& r) {
  std::vector<double> means, all;
  int skipped = 0;
  for (size_t i = 0; i < r.fits.size(); ++i) {
    if (!r.skip_reason[i].empty()) {
      ++skipped;
      continue;
    }
    means.push_back(r.fits[i].mean_mm);
    for (double d : r.fits[i].residual_mm)
      if (!std::isnan(d)) all.push_back(d);
  }
  double mean = 0;
  for (double d : all) mean += d;
  json fingers = json::object();
  for (const auto& [name, value] : finger_means(r)) fingers[name] = value;
  return {{"frames", r.fits.size()},
          {"fitted", r.fits.size() - skipped},
          {"skipped", skipped},
          {"mean_mm", all.empty() ? json(nullptr) : json(mean / all.size())},
          {"max_mm", all.empty() ? json(nullptr) : json(*std::max_element(all.begin(), all.end()))},
          {"per_finger_mean_mm", fingers},
          {"bone_length_error", bone_length_summary(r)},
          {"fit_ms_per_frame", r.ms_per_frame}};
}

void write_reports(const std::string& out, const std::array<SideResult, 2>& results) {
  json report = {{"hands", json::object()}, {"frames", json::array()}};
  std::string csv = "frame,hand,joint,residual_mm\n";
  for (int s = 0; s < 2; ++s) {
    const SideResult& r = results[s];
    if (r.fits.empty()) continue;
    report["hands"][kSides[s]] = side_summary(r);
    for (size_t f = 0; f < r.fits.size(); ++f) {
      const HandFit& fit = r.fits[f];
      json residual = json::object();
      for (int j = 0; j < 21; ++j) {
        residual[kMano21Names[j]] = std::isnan(fit.residual_mm[j]) ? json(nullptr) : json(fit.residual_mm[j]);
        if (!std::isnan(fit.residual_mm[j]))
          csv += r.names[f] + "," + kSides[s] + "," + kMano21Names[j] + "," + std::to_string(fit.residual_mm[j]) + "\n";
      }
      report["frames"].push_back({{"frame", r.names[f]},
                                  {"hand", kSides[s]},
                                  {"status", r.skip_reason[f].empty() ? "fitted" : "skipped: " + r.skip_reason[f]},
                                  {"mean_mm", fit.fitted ? json(fit.mean_mm) : json(nullptr)},
                                  {"max_mm", fit.fitted ? json(fit.max_mm) : json(nullptr)},
                                  {"residual_mm", residual}});
    }
  }
  write_file_atomic((fs::path(out) / "report.json").string(), report.dump(1) + "\n");
  write_file_atomic((fs::path(out) / "report.csv").string(), csv);
}

void log_summary(const std::array<SideResult, 2>& results) {
  for (int s = 0; s < 2; ++s) {
    const SideResult& r = results[s];
    if (r.fits.empty()) continue;
    const json sum = side_summary(r);
    auto mm = [](const json& v) { return v.is_null() ? std::string("-") : fmt::format("{:.2f}", v.get<double>()); };
    spdlog::info("{} hand: {} of {} frames fitted, mean residual {} mm, max {} mm, {:.2f} ms a frame", kSides[s],
                 sum["fitted"].get<int>(), sum["frames"].get<int>(), mm(sum["mean_mm"]), mm(sum["max_mm"]),
                 r.ms_per_frame);
    if (!sum["bone_length_error"].is_null())
      spdlog::info("{} hand: bone lengths, fitted minus keypoints: {} mm on average ({} mm apart, at most {} mm)",
                   kSides[s], mm(sum["bone_length_error"]["mean_mm"]), mm(sum["bone_length_error"]["mean_abs_mm"]),
                   mm(sum["bone_length_error"]["max_abs_mm"]));
    for (size_t f = 0; f < r.fits.size(); ++f)
      if (!r.skip_reason[f].empty()) spdlog::warn("{} hand, frame {}: skipped: {}", kSides[s], r.names[f], r.skip_reason[f]);
  }
}

// --- multi-view ---

// Which triangulated hand is right and which left: the assignment whose rigs fit best.
std::array<int, 2> assign_hands(const std::vector<TriangulatedHand>& hands, const std::array<JointModel, 2>& models,
                                const KeypointFitConfig& config) {
  std::array<int, 2> side_of_hand{-1, -1};  // hand index per side
  std::vector<std::array<double, 2>> cost(hands.size());
  for (size_t h = 0; h < hands.size(); ++h)
    for (int s = 0; s < 2; ++s)
      cost[h][s] = hands[h].keypoints.num_valid() >= kMinFitKeypoints
                       ? fit_keypoints(models[s], hands[h].keypoints, config).mean_mm
                       : INFINITY;
  if (hands.size() == 1) {
    side_of_hand[cost[0][0] <= cost[0][1] ? 0 : 1] = 0;
  } else if (hands.size() == 2) {
    const bool straight = cost[0][0] + cost[1][1] <= cost[0][1] + cost[1][0];
    side_of_hand = straight ? std::array<int, 2>{0, 1} : std::array<int, 2>{1, 0};
  }
  for (size_t h = 0; h < hands.size(); ++h)
    spdlog::info("hand {} ({} views): right rig {:.2f} mm, left rig {:.2f} mm", h, hands[h].detections.size(),
                 cost[h][0], cost[h][1]);
  return side_of_hand;
}

void write_multiview_outputs(const FitCommandOptions& o, const MultiviewCapture& cap,
                             const std::vector<TriangulatedHand>& hands, const std::array<int, 2>& side_of_hand,
                             const std::array<SideResult, 2>& results, const std::array<Rig, 2>& rigs,
                             const std::array<JointModel, 2>& models) {
  // capture.json in the project's layout, with links to the images and masks.
  json cameras = json::object();
  for (size_t v = 0; v < cap.cameras.size(); ++v) cameras["view" + cap.views[v]] = capture_camera_json(cap.cameras[v]);
  json frame = {{"frame", 0}, {"hand_type", side_of_hand[0] >= 0 && side_of_hand[1] >= 0 ? "interacting"
                                                 : side_of_hand[0] >= 0 ? "right" : "left"}};
  for (int s = 0; s < 2; ++s) {
    if (results[s].fits.empty() || !results[s].skip_reason[0].empty()) continue;
    const HandFit& fit = results[s].fits[0];
    const auto pose = rig_pose(models[s], fit.params, o.flat_hand_mean);
    frame[kSides[s]] = capture_hand_json(pose.data(), fit.params.shape.data(), fit.params.trans.data(), fit.joints.data());
  }
  const json capture = {{"format", kHandscsCaptureFormat}, {"version", kHandscsCaptureVersion},
                        {"flat_hand_mean", o.flat_hand_mean}, {"cameras", cameras},
                        {"frames", json::array({frame})}};
  write_file_atomic((fs::path(o.out) / "capture.json").string(), capture.dump(1) + "\n");
  bool with_regions = false;
  for (size_t v = 0; v < cap.cameras.size(); ++v) {
    const fs::path dir = fs::path(o.out) / "images" / ("view" + cap.views[v]);
    fs::create_directories(dir);
    const fs::path link = dir / (frame_file_stem(0) + fs::path(cap.images[v]).extension().string());
    fs::remove(link);
    fs::create_symlink(fs::absolute(cap.images[v]), link);
    // The capture's own masks (both hands in one) stand in for masks rasterised from the meshes,
    // and are the region "hands" that handscs-eval scores apart (docs/METRICS.md).
    if (cap.masks[v].empty()) continue;
    const fs::path mask_dir = fs::path(o.out) / "masks" / ("view" + cap.views[v]);
    fs::create_directories(mask_dir);
    const fs::path mask_link = mask_dir / (frame_file_stem(0) + ".png");
    fs::remove(mask_link);
    fs::create_symlink(fs::absolute(cap.masks[v]), mask_link);
    const cv::Mat mask = cv::imread(cap.masks[v], cv::IMREAD_GRAYSCALE);
    if (mask.empty()) throw Error(cap.masks[v] + ": cannot read the mask");
    const fs::path region_dir = fs::path(o.out) / "regions" / ("view" + cap.views[v]);
    fs::create_directories(region_dir);
    const cv::Mat region = (mask > 127) / 255;  // bit 1: the region "hands"
    write_png((region_dir / (frame_file_stem(0) + ".png")).string(), region);
    with_regions = true;
  }
  if (with_regions)
    write_file_atomic((fs::path(o.out) / "regions" / "regions.json").string(),
                      json{{"regions", {{{"name", "hands"}, {"bit", 1},
                                         {"description", "the capture's own hand mask"}}}}}.dump(1) + "\n");
  // Reprojection of the triangulated and the fitted joints against every view's landmarks.
  std::string csv = "view,hand,joints,triangulated_median_px,triangulated_p90_px,fitted_median_px,fitted_p90_px\n";
  json reprojection = json::object();
  for (int s = 0; s < 2; ++s) {
    const int h = side_of_hand[s];
    if (h < 0 || results[s].fits.empty() || !results[s].skip_reason[0].empty()) continue;
    std::vector<double> all_tri, all_fit;
    for (int d : hands[h].detections) {
      const Detection& det = cap.detections[d];
      const Camera& cam = cap.cameras[det.view];
      std::vector<double> tri, fit;
      for (int j = 0; j < 21; ++j) {
        if (!det.valid[j]) continue;
        const double* fj = &results[s].fits[0].joints[3 * j];
        fit.push_back(reprojection_error(cam, {fj[0], fj[1], fj[2]}, det.pixels[j]));
        if (hands[h].keypoints.valid[j]) {
          const double* tj = &hands[h].keypoints.joints[3 * j];
          tri.push_back(reprojection_error(cam, {tj[0], tj[1], tj[2]}, det.pixels[j]));
        }
      }
      all_tri.insert(all_tri.end(), tri.begin(), tri.end());
      all_fit.insert(all_fit.end(), fit.begin(), fit.end());
      csv += cap.views[det.view] + "," + kSides[s] + "," + std::to_string(fit.size()) + "," +
             std::to_string(percentile(tri, 0.5)) + "," + std::to_string(percentile(tri, 0.9)) + "," +
             std::to_string(percentile(fit, 0.5)) + "," + std::to_string(percentile(fit, 0.9)) + "\n";
    }
    json dropped = json::object();
    for (int j = 0; j < 21; ++j) {
      json views = json::array();
      for (int v : hands[h].dropped_views[j]) views.push_back(cap.views[v]);
      if (!views.empty()) dropped[kMano21Names[j]] = views;
    }
    json used = json::array();
    for (int d : hands[h].detections)
      used.push_back({{"view", cap.views[cap.detections[d].view]}, {"detector_label", cap.detections[d].label}});
    reprojection[kSides[s]] = {{"views", used},
                               {"triangulated_median_px", percentile(all_tri, 0.5)},
                               {"triangulated_p90_px", percentile(all_tri, 0.9)},
                               {"fitted_median_px", percentile(all_fit, 0.5)},
                               {"fitted_p90_px", percentile(all_fit, 0.9)},
                               {"dropped_views_per_joint", dropped}};
    spdlog::info("{} hand: {} views; reprojection against the landmarks: triangulated median {:.1f} px (p90 {:.1f}), "
                 "fitted median {:.1f} px (p90 {:.1f})", kSides[s], hands[h].detections.size(),
                 percentile(all_tri, 0.5), percentile(all_tri, 0.9), percentile(all_fit, 0.5), percentile(all_fit, 0.9));
  }
  write_file_atomic((fs::path(o.out) / "reprojection.csv").string(), csv);
  write_file_atomic((fs::path(o.out) / "reprojection.json").string(), reprojection.dump(1) + "\n");
  // The fitted meshes over the photographs.
  std::vector<int> views = o.overlay_views;
  if (views.empty())
    for (int i = 0; i < kDefaultOverlayViews && i < static_cast<int>(cap.cameras.size()); ++i)
      views.push_back(i * static_cast<int>(cap.cameras.size()) / kDefaultOverlayViews);
  std::vector<OverlayHand> drawn;
  const cv::Scalar colours[2] = {cv::Scalar(60, 180, 255), cv::Scalar(255, 160, 60)};  // right orange, left blue
  for (int s = 0; s < 2; ++s) {
    if (results[s].fits.empty() || !results[s].skip_reason[0].empty()) continue;
    const HandFit& fit = results[s].fits[0];
    const auto f64 = torch::kFloat64;
    const auto pose = torch::tensor(std::vector<double>(fit.params.pose.begin(), fit.params.pose.end()), f64);
    const auto shape = torch::tensor(std::vector<double>(fit.params.shape.begin(), fit.params.shape.end()), f64);
    const auto trans = torch::tensor(std::vector<double>(fit.params.trans.begin(), fit.params.trans.end()), f64);
    const LbsOutput posed = lbs_one_pose(rigs[s], pose, shape, trans, LbsOptions{true});
    drawn.push_back({&rigs[s], posed.vertices[0], fit.joints, colours[s]});
  }
  for (int v : views) {
    const cv::Mat photo = cv::imread(cap.images[v], cv::IMREAD_COLOR);
    if (photo.empty()) throw Error(cap.images[v] + ": cannot read the image");
    write_png((fs::path(o.out) / "overlay" / ("view" + cap.views[v] + ".png")).string(),
              draw_overlay(photo, cap.cameras[v], drawn, kOverlayMarginPx));
  }
}

// Each fitted frame's hands as capture.json entries, by the capture's frame number (`frame_of` a
// keypoint frame's name).
std::map<int64_t, std::array<json, 2>> fitted_hands(const std::array<SideResult, 2>& results,
                                                    const std::array<JointModel, 2>& models, const FitCommandOptions& o,
                                                    const std::map<std::string, int64_t>& frame_of) {
  std::map<int64_t, std::array<json, 2>> hands;
  for (int s = 0; s < 2; ++s)
    for (size_t f = 0; f < results[s].fits.size(); ++f) {
      if (!results[s].skip_reason[f].empty()) continue;
      const HandFit& fit = results[s].fits[f];
      const auto pose = rig_pose(models[s], fit.params, o.flat_hand_mean);
      hands[frame_of.at(results[s].names[f])][s] =
          capture_hand_json(pose.data(), fit.params.shape.data(), fit.params.trans.data(), fit.joints.data());
    }
  return hands;
}

}  // namespace

void run_fit_command(const FitCommandOptions& o) {
  const int inputs = !o.keypoints.empty() + !o.interhand_joints.empty() + !o.multiview.empty();
  if (inputs != 1) throw Error("give exactly one input: --keypoints, --interhand-joints or --multiview");
  if (!o.interhand_joints.empty() && o.capture < 0)
    throw Error("--interhand-joints needs --capture (the capture number of joint_3d.json)");
  if (!o.capture_dir.empty() && o.keypoints.empty())
    throw Error("--capture-dir goes with --keypoints (a multi-view capture writes its own capture.json; an "
                "InterHand2.6M capture trains from its joints with data.pose_source=joints)");
  FitCommandConfig config = load_config<FitCommandConfig>(o.config, o.overrides);
  const std::array<Rig, 2> rigs = {load_rig_source(o.rig_right), load_rig_source(o.rig_left)};
  if (rigs[0].handedness != Handedness::right) throw Error("--rig-right: " + o.rig_right + " is a left-hand rig");
  if (rigs[1].handedness != Handedness::left) throw Error("--rig-left: " + o.rig_left + " is a right-hand rig");
  const std::array<JointModel, 2> models = {make_joint_model(rigs[0]), make_joint_model(rigs[1])};
  const std::string stage = check_output(o);

  std::array<SideInput, 2> inputs_by_side;
  MultiviewCapture cap;
  std::vector<TriangulatedHand> hands;
  std::array<int, 2> side_of_hand{-1, -1};
  FittedCaptureSource target;  // --capture-dir
  std::map<std::string, int64_t> frame_of;  // --capture-dir: the capture's frame each keypoint frame names
  if (!o.multiview.empty()) {
    cap = read_multiview_capture(o.multiview);
    for (int v : o.overlay_views)
      if (v < 0 || v >= static_cast<int>(cap.cameras.size()))
        throw Error("--overlay-views: view " + std::to_string(v) + " is not in the capture (0-" +
                    std::to_string(cap.cameras.size() - 1) + ")");
    spdlog::info("{}: {} views, {} hand detections", o.multiview, cap.cameras.size(), cap.detections.size());
    hands = find_hands(cap.cameras, cap.detections, config.multiview);
    if (hands.empty())
      throw Error(o.multiview + ": no hand is seen by " + std::to_string(config.multiview.min_views) +
                  " views that agree (multiview.inlier_px " + std::to_string(config.multiview.inlier_px) + " px)");
    for (const TriangulatedHand& h : hands)
      for (int j : h.dropped_joints) spdlog::warn("joint {}: no two views agree; left out of the fit", kMano21Names[j]);
    side_of_hand = assign_hands(hands, models, config.fit);
    for (int s = 0; s < 2; ++s)
      if (side_of_hand[s] >= 0) {
        inputs_by_side[s].names.push_back("frame0");
        inputs_by_side[s].frames.push_back(hands[side_of_hand[s]].keypoints);
      }
  } else {
    const std::vector<KeypointFrame> frames = !o.keypoints.empty()
                                                  ? read_keypoint_file(o.keypoints)
                                                  : read_interhand_keypoints(o.interhand_joints, o.capture);
    if (!o.capture_dir.empty()) {
      target = read_fitted_capture_source(o.capture_dir, o.out);
      std::map<int64_t, std::string> named;  // checked before any fitting
      for (const KeypointFrame& f : frames) {
        const auto [it, fresh] = named.emplace(capture_frame_of(f.name, target, o.keypoints), f.name);
        if (!fresh)
          throw Error(o.keypoints + ": frames \"" + it->second + "\" and \"" + f.name + "\" both name frame " +
                      std::to_string(it->first) + " of " + o.capture_dir);
        frame_of[f.name] = it->first;
      }
    }
    for (const KeypointFrame& f : frames)
      for (int s = 0; s < 2; ++s) {
        const auto& hand = s == 0 ? f.right : f.left;
        if (!hand) continue;
        inputs_by_side[s].names.push_back(f.name);
        inputs_by_side[s].frames.push_back(*hand);
      }
    if (inputs_by_side[0].frames.empty() && inputs_by_side[1].frames.empty())
      throw Error((o.keypoints.empty() ? o.interhand_joints : o.keypoints) +
                  ": no frame holds a hand (every hand is null or has no valid point)");
  }
  std::array<SideResult, 2> results;
  for (int s = 0; s < 2; ++s)
    results[s] = fit_side(models[s], models[1 - s], inputs_by_side[s], config, kSides[s], o.multiview.empty());
  log_summary(results);
  // Nothing fitted is an error, not an empty result: the first skipped frame says why.
  bool any_fitted = false;
  for (const SideResult& r : results)
    for (const std::string& reason : r.skip_reason) any_fitted = any_fitted || reason.empty();
  if (!any_fitted)
    for (int s = 0; s < 2; ++s)
      if (!results[s].fits.empty())
        throw Error("no hand could be fitted; " + std::string(kSides[s]) + " hand, frame " + results[s].names[0] +
                    ": " + results[s].skip_reason[0]);
  fs::remove_all(stage);
  ensure_directory(stage);
  FitCommandOptions staged = o;  // every file goes to the staging folder first
  staged.out = stage;
  try {
    for (int s = 0; s < 2; ++s)
      if (!results[s].fits.empty())
        write_file_atomic((fs::path(stage) / ("poses_" + std::string(kSides[s]) + ".json")).string(),
                          poses_json(models[s], results[s], o.flat_hand_mean).dump(1) + "\n");
    write_reports(stage, results);
    if (!o.multiview.empty()) write_multiview_outputs(staged, cap, hands, side_of_hand, results, rigs, models);
    if (!o.capture_dir.empty()) write_fitted_capture(target, stage, o.flat_hand_mean, fitted_hands(results, models, o, frame_of));
    write_file_atomic((fs::path(stage) / kFitMarker).string(), config_to_json(config).dump(1) + "\n");
    finish_output(o, stage);
  } catch (...) {
    std::error_code ignored;  // the error that brought us here is the one to report
    fs::remove_all(stage, ignored);
    throw;
  }
  spdlog::info("wrote {}", o.out);
}

}  // namespace handscs
