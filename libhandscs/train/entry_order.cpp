#include "train/entry_order.h"

#include <algorithm>
#include <map>
#include <random>

namespace handscs {

EntryOrder::EntryOrder(const std::vector<FrameInfo>& frames, int64_t views_per_pose, int64_t seed)
    : frames_(frames), views_per_pose_(views_per_pose), seed_(seed) {
  if (views_per_pose_ == 1) return;
  std::map<int, std::vector<int64_t>> by_pose;  // ordered: the same grouping on every run
  for (size_t k = 0; k < frames_.size(); ++k) by_pose[frames_[k].pose_index].push_back(k);
  for (auto& [pose, positions] : by_pose) poses_.push_back(std::move(positions));
}

std::vector<const FrameInfo*> EntryOrder::frames_for(int64_t entry_index) {
  // One frame per entry, or one pose: the epoch runs over frames or over poses.
  const int64_t n = views_per_pose_ == 1 ? static_cast<int64_t>(frames_.size())
                                         : static_cast<int64_t>(poses_.size());
  const int64_t epoch = entry_index / n;
  if (epoch != order_epoch_) {
    order_.resize(n);
    for (int64_t i = 0; i < n; ++i) order_[i] = i;
    std::mt19937_64 rng(static_cast<uint64_t>(seed_) * 1000003ull + epoch);
    std::shuffle(order_.begin(), order_.end(), rng);
    order_epoch_ = epoch;
  }
  const int64_t picked = order_[entry_index % n];
  if (views_per_pose_ == 1) return {&frames_[picked]};
  // The pose's cameras in an order of (seed, entry) alone; the first views_per_pose of them.
  std::vector<int64_t> cameras = poses_[picked];
  std::mt19937_64 rng(static_cast<uint64_t>(seed_) * 2000029ull + entry_index);
  std::shuffle(cameras.begin(), cameras.end(), rng);
  cameras.resize(std::min<size_t>(cameras.size(), static_cast<size_t>(views_per_pose_)));
  std::vector<const FrameInfo*> out;
  for (const int64_t k : cameras) out.push_back(&frames_[k]);
  return out;
}

}  // namespace handscs
