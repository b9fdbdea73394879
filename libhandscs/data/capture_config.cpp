#include "data/capture_config.h"

#include "core/error.h"

namespace handscs {

const ChoiceNames<CaptureConfig::Layout>& CaptureConfig::layout_names() {
  static const ChoiceNames<Layout> names = {{"auto", Layout::automatic},
                                            {"interhand", Layout::interhand},
                                            {"handscs", Layout::handscs},
                                            {"easymocap", Layout::easymocap},
                                            {"neus", Layout::neus}};
  return names;
}

const ChoiceNames<CaptureConfig::Hands>& CaptureConfig::hand_names() {
  static const ChoiceNames<Hands> names = {
      {"right", Hands::right}, {"left", Hands::left}, {"both", Hands::both}};
  return names;
}

const ChoiceNames<CaptureConfig::SplitRule>& CaptureConfig::split_rule_names() {
  static const ChoiceNames<SplitRule> names = {{"novel_pose", SplitRule::novel_pose},
                                               {"novel_view", SplitRule::novel_view}};
  return names;
}

const ChoiceNames<CaptureConfig::PoseSource>& CaptureConfig::pose_source_names() {
  static const ChoiceNames<PoseSource> names = {{"mano", PoseSource::mano}, {"joints", PoseSource::joints}};
  return names;
}

const ChoiceNames<CaptureConfig::SuppliedMasks>& CaptureConfig::supplied_masks_names() {
  static const ChoiceNames<SuppliedMasks> names = {{"use", SuppliedMasks::use},
                                                   {"replace_poor", SuppliedMasks::replace_poor},
                                                   {"ignore", SuppliedMasks::ignore}};
  return names;
}

std::string layout_name(CaptureConfig::Layout layout) {
  return choice_name(layout, CaptureConfig::layout_names());
}
std::string hand_name(Handedness hand) { return hand == Handedness::right ? "right" : "left"; }
std::string hand_name(CaptureConfig::Hands hands) { return choice_name(hands, CaptureConfig::hand_names()); }

std::vector<Handedness> hand_sides(CaptureConfig::Hands hands) {
  switch (hands) {
    case CaptureConfig::Hands::right: return {Handedness::right};
    case CaptureConfig::Hands::left: return {Handedness::left};
    case CaptureConfig::Hands::both: break;
  }
  return {Handedness::right, Handedness::left};
}

Handedness single_hand(CaptureConfig::Hands hands, const std::string& what) {
  if (hands == CaptureConfig::Hands::both)
    throw Error(what + " handles one hand: data.hand is both (set right or left)");
  return hands == CaptureConfig::Hands::left ? Handedness::left : Handedness::right;
}
std::string split_rule_name(CaptureConfig::SplitRule rule) {
  return choice_name(rule, CaptureConfig::split_rule_names());
}
std::string pose_source_name(CaptureConfig::PoseSource source) {
  return choice_name(source, CaptureConfig::pose_source_names());
}

}  // namespace handscs
