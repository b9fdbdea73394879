#include "train/cull_component.h"

namespace handscs {

namespace {
// metrics.csv's column of the share decoded (a log without it gains the column when a resume
// turns the cull on, and keeps it, empty, when a resume turns it off: prepare_metrics_log).
constexpr const char* kDecodedFractionColumn = "decoded_fraction";
}  // namespace

void CullComponent::before_decode(EntryContext& entry) {
  entry.cull.emplace();
  entry.cull->max_cos = max_cos_;
  for (const ViewRender& view : entry.views) entry.cull->camera_centres.push_back(view.camera.centre());
}

void CullComponent::diagnostics(const EntryContext& entry, std::map<std::string, double>& values) {
  values[kDecodedFractionColumn] = entry.state->decoded_fraction();
}

std::vector<std::string> CullComponent::metrics_columns() const { return {kDecodedFractionColumn}; }

}  // namespace handscs
