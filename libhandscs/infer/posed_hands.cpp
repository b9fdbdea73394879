#include "infer/posed_hands.h"

#include <algorithm>

#include "core/error.h"

namespace handscs {

namespace {
int slot(Handedness side) { return side == Handedness::right ? 0 : 1; }
}  // namespace

PosedHands::PosedHands(TrainedAvatar& trained) {
  const std::vector<Handedness> sides = hand_sides(trained.trained_config.data.hand);
  two_hands_ = sides.size() > 1;
  first_ = sides.front();
  for (const Handedness side : sides)
    if (Avatar* avatar = trained.hand(side)) memos_[slot(side)] = std::make_unique<PoseMemo>(*avatar);
}

const PosedGaussians& PosedHands::pose_hands(const std::array<const HandParams*, 2>& hands,
                                             const std::string& where) {
  std::array<PoseMemo*, 2> memos{};
  std::array<HandPoseInput, 2> inputs{};
  for (int side = 0; side < 2; ++side) {
    posed_[side] = hands[side] && memos_[side];
    if (!posed_[side]) continue;
    memos[side] = memos_[side].get();
    inputs[side] = {hands[side]->pose.data(), hands[side]->shape.data(), hands[side]->trans.data()};
  }
  const std::array<const AvatarState*, 2> states = pose_side_by_side(memos, inputs);
  // What posing costs, memo hit or not: the slower hand when both were posed side by side.
  pose_ms_ = 0;
  const bool side_by_side = poses_side_by_side(memos, inputs);
  std::vector<const PosedGaussians*> sets;
  for (int side = 0; side < 2; ++side) {
    if (!states[side]) continue;
    sets.push_back(&states[side]->posed);
    const double ms = memos_[side]->pose_ms();
    pose_ms_ = side_by_side ? std::max(pose_ms_, ms) : pose_ms_ + ms;
  }
  if (sets.empty()) throw Error(where + ": the frame has neither of the avatar's hands");
  joined_ = join_posed(sets);
  return joined_;
}

double PosedHands::pose_ms() const { return pose_ms_; }

int64_t PosedHands::computed() const {
  int64_t n = 0;
  for (const auto& memo : memos_)
    if (memo) n += memo->computed();
  return n;
}

int64_t PosedHands::reused() const {
  int64_t n = 0;
  for (const auto& memo : memos_)
    if (memo) n += memo->reused();
  return n;
}

const AvatarState* PosedHands::state(Handedness side) const {
  return posed_[slot(side)] ? memos_[slot(side)]->last() : nullptr;
}

}  // namespace handscs
