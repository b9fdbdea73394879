// MANO fit error of the annotations (NeuralAnnot-like): each annotated value is the rendered one
// plus a smooth zero-mean error e(t) = a sum_{k<3} sin(2 pi t / P_k + phi_k), periods P_k uniform in
// [0.6, 1.6] x the configured period and random phases, a = sigma sqrt(2/3) so the error's RMS over
// time is sigma. Rotation errors are applied per joint as sigma per component = angle / sqrt(3), so
// the RMS rotation angle per joint is the configured one; translation likewise per vector length.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "synth/effects.h"

namespace handscs {

struct FitError {
  std::array<double, 48> pose{};   // added to the absolute axis-angle pose (rad)
  std::array<double, 3> trans{};   // added to trans (m)
  std::array<double, 10> shape{};  // added to the shape coefficients
};

// One error per frame (frame k at time k), deterministic from the seed.
std::vector<FitError> make_fit_errors(const SynthEffects& effects, int num_frames, uint64_t seed);

}  // namespace handscs
