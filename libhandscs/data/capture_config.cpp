#include "data/capture_config.h"

namespace handscs {

const ChoiceNames<CaptureConfig::Layout>& CaptureConfig::layout_names() {
  static const ChoiceNames<Layout> names = {{"auto", Layout::automatic},
                                            {"interhand", Layout::interhand},
                                            {"handscs", Layout::handscs},
                                            {"easymocap", Layout::easymocap},
                                            {"neus", Layout::neus}};
  return names;
}

const ChoiceNames<Handedness>& CaptureConfig::hand_names() {
  static const ChoiceNames<Handedness> names = {{"right", Handedness::right}, {"left", Handedness::left}};
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

std::string layout_name(CaptureConfig::Layout layout) {
  return choice_name(layout, CaptureConfig::layout_names());
}
std::string hand_name(Handedness hand) { return choice_name(hand, CaptureConfig::hand_names()); }
std::string split_rule_name(CaptureConfig::SplitRule rule) {
  return choice_name(rule, CaptureConfig::split_rule_names());
}
std::string pose_source_name(CaptureConfig::PoseSource source) {
  return choice_name(source, CaptureConfig::pose_source_names());
}

}  // namespace handscs
