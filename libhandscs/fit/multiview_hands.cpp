#include "fit/multiview_hands.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "fit/triangulation.h"

namespace handscs {

namespace {

// A later group lying closer than this to an earlier hand (mean over their shared joints), seen
// mostly in views where that hand was not, is the earlier hand again: its detections that missed
// inlier_px agree with each other and triangulate 9-28 mm from it (docs/FIT.md, MediaPipe at 10 px).
// Two real hands palm to palm come as close, but each is seen beside the other in most views.
constexpr double kSameHandMm = 40.0;

Vec3 joint_at(const double* joints, int j) { return {joints[3 * j], joints[3 * j + 1], joints[3 * j + 2]}; }

// Mean distance (mm) between the joints two hands both have; infinity when they share fewer than
// a fit needs (a distance from one or two joints says little about where a hand lies).
double mean_joint_distance_mm(const HandKeypoints& a, const HandKeypoints& b) {
  double sum = 0;
  int count = 0;
  for (int j = 0; j < 21; ++j)
    if (a.valid[j] && b.valid[j]) {
      sum += norm(joint_at(a.joints.data(), j) - joint_at(b.joints.data(), j));
      ++count;
    }
  return count >= kMinFitKeypoints ? 1000.0 * sum / count : std::numeric_limits<double>::infinity();
}

// The earlier hand `hand` repeats (see kSameHandMm), or -1.
int repeated_hand(const TriangulatedHand& hand, const std::vector<TriangulatedHand>& earlier,
                  const std::vector<Detection>& detections) {
  for (size_t e = 0; e < earlier.size(); ++e) {
    if (mean_joint_distance_mm(hand.keypoints, earlier[e].keypoints) >= kSameHandMm) continue;
    size_t shared_views = 0;
    for (int d : hand.detections)
      for (int o : earlier[e].detections) shared_views += detections[d].view == detections[o].view;
    if (2 * shared_views < hand.detections.size()) return static_cast<int>(e);
  }
  return -1;
}

struct Hypothesis {
  std::vector<int> support;  // detections, one per view
  double error = std::numeric_limits<double>::infinity();
};

// The hand two detections propose (each joint from the two views), and the detections of every
// view that agree with it (the closest detection of each view, if within inlier_px).
Hypothesis support_of(const std::vector<Camera>& cameras, const std::vector<Detection>& detections,
                      const std::vector<bool>& taken, int a, int b, double inlier_px) {
  std::array<double, 63> joints{};
  std::array<uint8_t, 21> valid{};
  for (int j = 0; j < 21; ++j) {
    if (!detections[a].valid[j] || !detections[b].valid[j]) continue;
    Vec3 X;
    if (!triangulate(cameras, {{detections[a].view, detections[a].pixels[j]},
                               {detections[b].view, detections[b].pixels[j]}}, X))
      continue;
    for (int c = 0; c < 3; ++c) joints[3 * j + c] = X[c];
    valid[j] = 1;
  }
  Hypothesis h;
  if (std::count(valid.begin(), valid.end(), 1) < kMinFitKeypoints) return h;
  std::map<int, std::pair<double, int>> best_per_view;  // view -> (median px, detection)
  for (int d = 0; d < static_cast<int>(detections.size()); ++d) {
    if (taken[d]) continue;
    const double e = median_reprojection_px(cameras.at(detections[d].view), detections[d], joints.data(), valid);
    if (e > inlier_px) continue;
    auto it = best_per_view.find(detections[d].view);
    if (it == best_per_view.end() || e < it->second.first) best_per_view[detections[d].view] = {e, d};
  }
  h.error = 0;
  for (const auto& [view, entry] : best_per_view) {
    h.support.push_back(entry.second);
    h.error += entry.first;
  }
  return h;
}

TriangulatedHand triangulate_hand(const std::vector<Camera>& cameras,
                                  const std::vector<Detection>& detections,
                                  const std::vector<int>& members, double inlier_px) {
  TriangulatedHand hand;
  hand.detections = members;
  for (int j = 0; j < 21; ++j) {
    std::vector<Observation> obs;
    for (int d : members)
      if (detections[d].valid[j]) obs.push_back({detections[d].view, detections[d].pixels[j]});
    const RobustPoint p = triangulate_robust(cameras, obs, inlier_px);
    if (!p.ok) {
      hand.dropped_joints.push_back(j);
      for (const Observation& o : obs) hand.dropped_views[j].push_back(o.view);
      continue;
    }
    for (int c = 0; c < 3; ++c) hand.keypoints.joints[3 * j + c] = p.point[c];
    hand.keypoints.valid[j] = 1;
    for (int i : p.inliers) hand.used_views[j].push_back(obs[i].view);
    for (int i : p.dropped) hand.dropped_views[j].push_back(obs[i].view);
  }
  return hand;
}

}  // namespace

double median_reprojection_px(const Camera& camera, const Detection& detection, const double* joints,
                              const std::array<uint8_t, 21>& joints_valid) {
  std::vector<double> errors;
  for (int j = 0; j < 21; ++j)
    if (detection.valid[j] && joints_valid[j])
      errors.push_back(reprojection_error(camera, joint_at(joints, j), detection.pixels[j]));
  if (errors.empty()) return std::numeric_limits<double>::infinity();
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  return errors[errors.size() / 2];
}

std::vector<TriangulatedHand> find_hands(const std::vector<Camera>& cameras,
                                         const std::vector<Detection>& detections,
                                         const MultiviewConfig& config) {
  std::vector<TriangulatedHand> hands;
  std::vector<bool> taken(detections.size(), false);
  const int n = static_cast<int>(detections.size());
  // Each round takes at least min_views detections, so n rounds end it.
  for (int round = 0; static_cast<int>(hands.size()) < config.max_hands && round < n; ++round) {
    Hypothesis best;
    for (int a = 0; a < n; ++a)
      for (int b = a + 1; b < n; ++b) {
        if (taken[a] || taken[b] || detections[a].view == detections[b].view) continue;
        Hypothesis h = support_of(cameras, detections, taken, a, b, config.inlier_px);
        if (h.support.size() > best.support.size() ||
            (h.support.size() == best.support.size() && h.error < best.error))
          best = std::move(h);
      }
    if (static_cast<int>(best.support.size()) < config.min_views) break;
    for (int d : best.support) taken[d] = true;
    TriangulatedHand hand = triangulate_hand(cameras, detections, best.support, config.inlier_px);
    const int repeated = repeated_hand(hand, hands, detections);
    if (repeated >= 0) {
      auto& into = hands[repeated].repeated_detections;
      into.insert(into.end(), best.support.begin(), best.support.end());
      continue;
    }
    hands.push_back(std::move(hand));
  }
  return hands;
}

}  // namespace handscs
