#include "fit/fit_command.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "core/atomic_file.h"
#include "core/config.h"
#include "core/text.h"  // join
#include "data/capture_json.h"
#include "data/handscs_capture.h"
#include "fit/fitted_capture.h"
#include "fit/keypoint_file.h"
#include "fit/multiview_capture.h"
#include "fit/multiview_outputs.h"
#include "hand/joint_order.h"

namespace handscs {

namespace fs = std::filesystem;

namespace {

// Frames of a sequence on which the other hand's rig is tried as well (evenly spaced): enough to
// tell a swapped hand, a fraction of the fit's time on a long capture.
constexpr int kHandednessSamples = 10;

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
    if (mirrored < kSwappedHandRatio * own)
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
    report["hands"][hand_name(kFitSides[s])] = side_summary(r);
    for (size_t f = 0; f < r.fits.size(); ++f) {
      const HandFit& fit = r.fits[f];
      json residual = json::object();
      for (int j = 0; j < 21; ++j) {
        residual[kMano21Names[j]] = std::isnan(fit.residual_mm[j]) ? json(nullptr) : json(fit.residual_mm[j]);
        if (!std::isnan(fit.residual_mm[j]))
          csv += r.names[f] + "," + hand_name(kFitSides[s]) + "," + kMano21Names[j] + "," + std::to_string(fit.residual_mm[j]) + "\n";
      }
      report["frames"].push_back({{"frame", r.names[f]},
                                  {"hand", hand_name(kFitSides[s])},
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
    spdlog::info("{} hand: {} of {} frames fitted, mean residual {} mm, max {} mm, {:.2f} ms a frame", hand_name(kFitSides[s]),
                 sum["fitted"].get<int>(), sum["frames"].get<int>(), mm(sum["mean_mm"]), mm(sum["max_mm"]),
                 r.ms_per_frame);
    if (!sum["bone_length_error"].is_null())
      spdlog::info("{} hand: bone lengths, fitted minus keypoints: {} mm on average ({} mm apart, at most {} mm)",
                   hand_name(kFitSides[s]), mm(sum["bone_length_error"]["mean_mm"]), mm(sum["bone_length_error"]["mean_abs_mm"]),
                   mm(sum["bone_length_error"]["max_abs_mm"]));
    for (size_t f = 0; f < r.fits.size(); ++f)
      if (!r.skip_reason[f].empty()) spdlog::warn("{} hand, frame {}: skipped: {}", hand_name(kFitSides[s]), r.names[f], r.skip_reason[f]);
  }
}

// --- multi-view ---

// Which triangulated hand is right and which left: the assignment whose rigs fit best. Logs each
// hand's residuals at `level` (a sequence's instants at debug).
std::array<int, 2> assign_hands(const std::vector<TriangulatedHand>& hands, const std::array<JointModel, 2>& models,
                                const KeypointFitConfig& config, spdlog::level::level_enum level) {
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
    spdlog::log(level, "hand {} ({} views): right rig {:.2f} mm, left rig {:.2f} mm", h, hands[h].detections.size(),
                cost[h][0], cost[h][1]);
  return side_of_hand;
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
  std::vector<MultiviewInstantFit> instant_fits;        // --multiview: by instant
  std::array<std::vector<size_t>, 2> instant_of_input;  // --multiview: each side's input frame's instant
  FittedCaptureSource target;  // --capture-dir
  std::map<std::string, int64_t> frame_of;  // --capture-dir: the capture's frame each keypoint frame names
  if (!o.multiview.empty()) {
    cap = read_multiview_capture(o.multiview);
    for (int v : o.overlay_views)
      if (v < 0 || v >= static_cast<int>(cap.cameras.size()))
        throw Error("--overlay-views: view " + std::to_string(v) + " is not in the capture (0-" +
                    std::to_string(cap.cameras.size() - 1) + ")");
    size_t detections = 0;
    for (const MultiviewInstant& instant : cap.instants) detections += instant.detections.size();
    spdlog::info("{}: {} views, {} instant{}, {} hand detections", o.multiview, cap.cameras.size(),
                 cap.instants.size(), cap.instants.size() == 1 ? "" : "s", detections);
    const std::string unseen = "no hand is seen by " + std::to_string(config.multiview.min_views) +
                               " views that agree (multiview.inlier_px " +
                               std::to_string(config.multiview.inlier_px) + " px)";
    instant_fits.resize(cap.instants.size());
    for (size_t i = 0; i < cap.instants.size(); ++i) {
      const MultiviewInstant& instant = cap.instants[i];
      MultiviewInstantFit& fit = instant_fits[i];
      const std::string where = cap.sequence ? "frame " + std::to_string(instant.frame) + ": " : "";
      fit.hands = find_hands(cap.cameras, instant.detections, config.multiview);
      if (fit.hands.empty()) {
        if (!cap.sequence) throw Error(o.multiview + ": " + unseen);
        spdlog::warn("{}: {}{}; not fitted", o.multiview, where, unseen);
        continue;
      }
      for (const TriangulatedHand& h : fit.hands)
        for (int j : h.dropped_joints)
          spdlog::warn("{}joint {}: no two views agree; left out of the fit", where, kMano21Names[j]);
      fit.side_of_hand = assign_hands(fit.hands, models, config.fit,
                                      cap.sequence ? spdlog::level::debug : spdlog::level::info);
      for (int s = 0; s < 2; ++s) {
        if (fit.side_of_hand[s] < 0) continue;
        const std::vector<int>& repeated = fit.hands[fit.side_of_hand[s]].repeated_detections;
        if (repeated.empty()) continue;
        std::vector<std::string> views;
        for (int d : repeated) views.push_back(cap.views[instant.detections[d].view]);
        spdlog::log(cap.sequence ? spdlog::level::debug : spdlog::level::info,
                    "{}the detections of views {} show the {} hand again, beyond multiview.inlier_px ({} px) "
                    "of its landmarks elsewhere: left out, not taken for a second hand",
                    where, join(views, ", "), hand_name(kFitSides[s]),
                    config.multiview.inlier_px);
      }
      for (int s = 0; s < 2; ++s)
        if (fit.side_of_hand[s] >= 0) {
          inputs_by_side[s].names.push_back(frame_file_stem(instant.frame));
          inputs_by_side[s].frames.push_back(fit.hands[fit.side_of_hand[s]].keypoints);
          instant_of_input[s].push_back(i);
        }
    }
    if (inputs_by_side[0].frames.empty() && inputs_by_side[1].frames.empty())
      throw Error(o.multiview + ": in no instant is a hand seen (" + unseen + ")");
    // The instant to draw must have a hand before any fitting.
    bool drawable = o.overlay_frame < 0;
    for (size_t i = 0; i < cap.instants.size(); ++i)
      drawable = drawable || (cap.instants[i].frame == o.overlay_frame && !instant_fits[i].hands.empty());
    if (!drawable)
      throw Error("--overlay-frame: " + o.multiview + " has no frame " + std::to_string(o.overlay_frame) +
                  " with a hand seen by its landmarks");
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
    results[s] = fit_side(models[s], models[1 - s], inputs_by_side[s], config, hand_name(kFitSides[s]), o.multiview.empty());
  log_summary(results);
  // Nothing fitted is an error, not an empty result: the first skipped frame says why.
  bool any_fitted = false;
  for (const SideResult& r : results)
    for (const std::string& reason : r.skip_reason) any_fitted = any_fitted || reason.empty();
  if (!any_fitted)
    for (int s = 0; s < 2; ++s)
      if (!results[s].fits.empty())
        throw Error("no hand could be fitted; " + hand_name(kFitSides[s]) + " hand, frame " + results[s].names[0] +
                    ": " + results[s].skip_reason[0]);
  fs::remove_all(stage);
  ensure_directory(stage);
  try {
    for (int s = 0; s < 2; ++s)
      if (!results[s].fits.empty())
        write_file_atomic((fs::path(stage) / ("poses_" + hand_name(kFitSides[s]) + ".json")).string(),
                          poses_json(models[s], results[s], o.flat_hand_mean).dump(1) + "\n");
    write_reports(stage, results);
    if (!o.multiview.empty()) {
      for (int s = 0; s < 2; ++s)
        for (size_t k = 0; k < results[s].fits.size(); ++k)
          if (results[s].skip_reason[k].empty()) instant_fits[instant_of_input[s][k]].fits[s] = &results[s].fits[k];
      write_multiview_outputs({stage, o.flat_hand_mean, o.overlay_views, o.overlay_frame}, cap, instant_fits, rigs,
                              models);
    }
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
