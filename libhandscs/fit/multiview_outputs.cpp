#include "fit/multiview_outputs.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <spdlog/spdlog.h>

#include "core/atomic_file.h"
#include "core/config.h"
#include "data/capture_json.h"
#include "data/handscs_capture.h"
#include "fit/overlay.h"
#include "fit/triangulation.h"
#include "hand/joint_order.h"
#include "hand/lbs_one_pose.h"
#include "io/png.h"

namespace handscs {

namespace fs = std::filesystem;

namespace {

// Views drawn when none are named: this many, evenly spread over the capture.
constexpr int kDefaultOverlayViews = 4;
// Pixels kept around the hands when an overlay is cropped to them: room for the joints' markers.
constexpr int kOverlayMarginPx = 40;

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return std::nan("");
  std::sort(values.begin(), values.end());
  const double at = q * (values.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(at)), hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (values[hi] - values[lo]) * (at - lo);
}

// Links `target` as `link`, replacing a link left there.
void link_file(const std::string& target, const fs::path& link) {
  fs::create_directories(link.parent_path());
  fs::remove(link);
  fs::create_symlink(fs::absolute(target), link);
}

// capture.json in the project's layout, one frame per instant with a fitted hand.
void write_capture_json(const MultiviewOutputOptions& o, const MultiviewCapture& cap,
                        const std::vector<MultiviewInstantFit>& fits, const std::array<JointModel, 2>& models) {
  json cameras = json::object();
  for (size_t v = 0; v < cap.cameras.size(); ++v) cameras["view" + cap.views[v]] = capture_camera_json(cap.cameras[v]);
  json frames = json::array();
  for (size_t i = 0; i < cap.instants.size(); ++i) {
    const auto& fitted = fits[i].fits;
    if (!fitted[0] && !fitted[1]) continue;
    json frame = {{"frame", cap.instants[i].frame},
                  {"hand_type", fitted[0] && fitted[1] ? "interacting" : fitted[0] ? "right" : "left"}};
    for (int s = 0; s < 2; ++s) {
      if (!fitted[s]) continue;
      const HandFit& fit = *fitted[s];
      const auto pose = rig_pose(models[s], fit.params, o.flat_hand_mean);
      frame[hand_name(kFitSides[s])] =
          capture_hand_json(pose.data(), fit.params.shape.data(), fit.params.trans.data(), fit.joints.data());
    }
    frames.push_back(frame);
  }
  const json capture = {{"format", kHandscsCaptureFormat}, {"version", kHandscsCaptureVersion},
                        {"flat_hand_mean", o.flat_hand_mean}, {"cameras", cameras}, {"frames", frames}};
  write_file_atomic((fs::path(o.out) / "capture.json").string(), capture.dump(1) + "\n");
}

// Every instant's images and masks linked; the capture's own masks (both hands in one) stand in for
// masks rasterised from the meshes, and are the region "hands" that handscs-eval scores apart
// (docs/METRICS.md).
void link_images(const MultiviewOutputOptions& o, const MultiviewCapture& cap,
                 const std::vector<MultiviewInstantFit>& fits) {
  bool with_regions = false;
  for (size_t i = 0; i < cap.instants.size(); ++i) {
    if (!fits[i].fits[0] && !fits[i].fits[1]) continue;
    const MultiviewInstant& instant = cap.instants[i];
    const std::string stem = frame_file_stem(instant.frame);
    for (size_t v = 0; v < cap.views.size(); ++v) {
      const std::string view = "view" + cap.views[v];
      if (instant.images[v].empty()) continue;
      link_file(instant.images[v],
                fs::path(o.out) / "images" / view / (stem + fs::path(instant.images[v]).extension().string()));
      if (instant.masks[v].empty()) continue;
      link_file(instant.masks[v], fs::path(o.out) / "masks" / view / (stem + ".png"));
      const cv::Mat mask = cv::imread(instant.masks[v], cv::IMREAD_GRAYSCALE);
      if (mask.empty()) throw Error(instant.masks[v] + ": cannot read the mask");
      const fs::path region_dir = fs::path(o.out) / "regions" / view;
      fs::create_directories(region_dir);
      const cv::Mat region = (mask > 127) / 255;  // bit 1: the region "hands"
      write_png((region_dir / (stem + ".png")).string(), region);
      with_regions = true;
    }
  }
  if (with_regions)
    write_file_atomic((fs::path(o.out) / "regions" / "regions.json").string(),
                      json{{"regions", {{{"name", "hands"}, {"bit", 1},
                                         {"description", "the capture's own hand mask"}}}}}.dump(1) + "\n");
}

// Reprojection of the triangulated and the fitted joints against every view's landmarks: a row per
// instant, view and hand, and per hand the figures over all instants with each instant's views.
void write_reprojection(const MultiviewOutputOptions& o, const MultiviewCapture& cap,
                        const std::vector<MultiviewInstantFit>& fits) {
  std::string csv = "frame,view,hand,joints,triangulated_median_px,triangulated_p90_px,fitted_median_px,fitted_p90_px\n";
  json reprojection = json::object();
  for (int s = 0; s < 2; ++s) {
    std::vector<double> all_tri, all_fit;
    json frames = json::object();
    int views_used = 0;
    for (size_t i = 0; i < cap.instants.size(); ++i) {
      const int h = fits[i].side_of_hand[s];
      const HandFit* fitted = fits[i].fits[s];
      if (h < 0 || !fitted) continue;
      const MultiviewInstant& instant = cap.instants[i];
      const TriangulatedHand& hand = fits[i].hands[h];
      const std::string stem = frame_file_stem(instant.frame);
      std::vector<double> frame_tri, frame_fit;
      for (int d : hand.detections) {
        const Detection& det = instant.detections[d];
        const Camera& cam = cap.cameras[det.view];
        std::vector<double> tri, fit;
        for (int j = 0; j < 21; ++j) {
          if (!det.valid[j]) continue;
          const double* fj = &fitted->joints[3 * j];
          fit.push_back(reprojection_error(cam, {fj[0], fj[1], fj[2]}, det.pixels[j]));
          if (hand.keypoints.valid[j]) {
            const double* tj = &hand.keypoints.joints[3 * j];
            tri.push_back(reprojection_error(cam, {tj[0], tj[1], tj[2]}, det.pixels[j]));
          }
        }
        frame_tri.insert(frame_tri.end(), tri.begin(), tri.end());
        frame_fit.insert(frame_fit.end(), fit.begin(), fit.end());
        csv += stem + "," + cap.views[det.view] + "," + hand_name(kFitSides[s]) + "," + std::to_string(fit.size()) + "," +
               std::to_string(percentile(tri, 0.5)) + "," + std::to_string(percentile(tri, 0.9)) + "," +
               std::to_string(percentile(fit, 0.5)) + "," + std::to_string(percentile(fit, 0.9)) + "\n";
      }
      json dropped = json::object();
      for (int j = 0; j < 21; ++j) {
        json views = json::array();
        for (int v : hand.dropped_views[j]) views.push_back(cap.views[v]);
        if (!views.empty()) dropped[kMano21Names[j]] = views;
      }
      json used = json::array();
      for (int d : hand.detections)
        used.push_back({{"view", cap.views[instant.detections[d].view]},
                        {"detector_label", instant.detections[d].label}});
      frames[stem] = {{"views", used},
                      {"triangulated_median_px", percentile(frame_tri, 0.5)},
                      {"fitted_median_px", percentile(frame_fit, 0.5)},
                      {"dropped_views_per_joint", dropped}};
      views_used += static_cast<int>(hand.detections.size());
      all_tri.insert(all_tri.end(), frame_tri.begin(), frame_tri.end());
      all_fit.insert(all_fit.end(), frame_fit.begin(), frame_fit.end());
    }
    if (frames.empty()) continue;
    reprojection[hand_name(kFitSides[s])] = {{"triangulated_median_px", percentile(all_tri, 0.5)},
                                   {"triangulated_p90_px", percentile(all_tri, 0.9)},
                                   {"fitted_median_px", percentile(all_fit, 0.5)},
                                   {"fitted_p90_px", percentile(all_fit, 0.9)},
                                   {"frames", frames}};
    spdlog::info("{} hand: {} views over {} frame{}; reprojection against the landmarks: triangulated median "
                 "{:.1f} px (p90 {:.1f}), fitted median {:.1f} px (p90 {:.1f})",
                 hand_name(kFitSides[s]), views_used, frames.size(), frames.size() == 1 ? "" : "s", percentile(all_tri, 0.5),
                 percentile(all_tri, 0.9), percentile(all_fit, 0.5), percentile(all_fit, 0.9));
  }
  write_file_atomic((fs::path(o.out) / "reprojection.csv").string(), csv);
  write_file_atomic((fs::path(o.out) / "reprojection.json").string(), reprojection.dump(1) + "\n");
}

// The fitted meshes over the photographs of one instant.
void write_overlays(const MultiviewOutputOptions& o, const MultiviewCapture& cap,
                    const std::vector<MultiviewInstantFit>& fits, const std::array<Rig, 2>& rigs) {
  int drawn_instant = -1;
  for (size_t i = 0; i < cap.instants.size() && drawn_instant < 0; ++i)
    if ((fits[i].fits[0] || fits[i].fits[1]) && (o.overlay_frame < 0 || cap.instants[i].frame == o.overlay_frame))
      drawn_instant = static_cast<int>(i);
  if (drawn_instant < 0)
    throw Error("--overlay-frame: frame " + std::to_string(o.overlay_frame) + " of " + cap.root +
                " has no fitted hand");
  const MultiviewInstant& instant = cap.instants[drawn_instant];
  std::vector<int> views = o.overlay_views;
  if (views.empty())
    for (int i = 0; i < kDefaultOverlayViews && i < static_cast<int>(cap.cameras.size()); ++i)
      views.push_back(i * static_cast<int>(cap.cameras.size()) / kDefaultOverlayViews);
  std::vector<OverlayHand> drawn;
  const cv::Scalar colours[2] = {cv::Scalar(60, 180, 255), cv::Scalar(255, 160, 60)};  // right orange, left blue
  for (int s = 0; s < 2; ++s) {
    const HandFit* fit = fits[drawn_instant].fits[s];
    if (!fit) continue;
    const auto f64 = torch::kFloat64;
    const auto pose = torch::tensor(std::vector<double>(fit->params.pose.begin(), fit->params.pose.end()), f64);
    const auto shape = torch::tensor(std::vector<double>(fit->params.shape.begin(), fit->params.shape.end()), f64);
    const auto trans = torch::tensor(std::vector<double>(fit->params.trans.begin(), fit->params.trans.end()), f64);
    const LbsOutput posed = lbs_one_pose(rigs[s], pose, shape, trans, LbsOptions{true});
    drawn.push_back({&rigs[s], posed.vertices[0], fit->joints, colours[s]});
  }
  if (cap.sequence) spdlog::info("overlays: frame {}", instant.frame);
  for (int v : views) {
    if (instant.images[v].empty()) {
      spdlog::warn("overlays: view {} has no image at frame {}; not drawn", cap.views[v], instant.frame);
      continue;
    }
    const cv::Mat photo = cv::imread(instant.images[v], cv::IMREAD_COLOR);
    if (photo.empty()) throw Error(instant.images[v] + ": cannot read the image");
    write_png((fs::path(o.out) / "overlay" / ("view" + cap.views[v] + ".png")).string(),
              draw_overlay(photo, cap.cameras[v], drawn, kOverlayMarginPx));
  }
}

}  // namespace

void write_multiview_outputs(const MultiviewOutputOptions& options, const MultiviewCapture& cap,
                             const std::vector<MultiviewInstantFit>& fits, const std::array<Rig, 2>& rigs,
                             const std::array<JointModel, 2>& models) {
  write_capture_json(options, cap, fits, models);
  link_images(options, cap, fits);
  write_reprojection(options, cap, fits);
  write_overlays(options, cap, fits, rigs);
}

}  // namespace handscs
