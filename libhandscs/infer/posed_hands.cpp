#include "infer/posed_hands.h"

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
  std::vector<const PosedGaussians*> sets;
  pose_ms_ = 0;
  for (int side = 0; side < 2; ++side) {
    posed_[side] = hands[side] && memos_[side];
    if (!posed_[side]) continue;
    const HandParams& p = *hands[side];
    sets.push_back(&memos_[side]->pose(p.pose.data(), p.shape.data(), p.trans.data()).posed);
    pose_ms_ += memos_[side]->pose_ms();
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
