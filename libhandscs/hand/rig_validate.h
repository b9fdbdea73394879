// Consistency checks of a rig (shapes, finite values, index ranges, weights summing to 1, MANO
// parents). Used by load_rig and save_rig; errors read "<source>: <key>: <problem>".
#pragma once

#include <string>

#include "hand/rig.h"

namespace handscs {

// Tolerance on |sum_k w_vk - 1| (and on negative weights): MANO's float32-born weights sum to 1
// within about 1e-7; 1e-4 accepts them and rejects any real mistake. The joint regressor's row sums
// are not checked (a user's MANO file is taken as it is).
constexpr double kRigSumTolerance = 1e-4;

// Throws Error naming `source` and the offending key when the rig is inconsistent.
void validate_rig(const Rig& rig, const std::string& source);

}  // namespace handscs
