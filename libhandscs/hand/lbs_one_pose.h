// Linear blend skinning of one pose in plain loops, for inference (issue 13): the outputs of lbs()
// with B = 1, without its ~150 small LibTorch ops and without converting the rig's blend shapes
// (~320k values) to the pose's dtype on every call. Computed in double from the rig's float64
// arrays and returned in the pose's dtype, so it is lbs() in double rounded once; no autograd.
// Agreement with lbs(): tests/hand/test_lbs_one_pose.cpp.
#pragma once

#include <torch/types.h>

#include "hand/lbs.h"
#include "hand/rig.h"

namespace handscs {

// pose: 48 values (axis-angle), shape: 10, trans: 3, each [n] or [1, n], float32 or float64 (the
// outputs' dtype follows pose). Every output has a leading batch dimension of 1, as lbs() gives.
LbsOutput lbs_one_pose(const Rig& rig, const torch::Tensor& pose, const torch::Tensor& shape,
                       const torch::Tensor& trans, const LbsOptions& options = {});

}  // namespace handscs
