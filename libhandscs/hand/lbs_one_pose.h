// Linear blend skinning of one pose in plain loops, wherever no gradient must reach the pose, shape
// or translation: inference, and training without pose refinement. The outputs of lbs()
// with B = 1, without its ~150 small LibTorch ops and without converting the rig's blend shapes
// (~320k values) to the pose's dtype on every call. Computed in double from the rig's float64
// arrays and returned in the pose's dtype, so it is lbs() in double rounded once; no autograd.
// Agreement with lbs(): tests/hand/test_lbs.cpp.
#pragma once

#include <torch/types.h>

#include "hand/lbs.h"
#include "hand/rig.h"

namespace handscs {

// Every output has a leading batch dimension of 1, as lbs() gives; the outputs' dtype follows pose.
LbsOutput lbs_one_pose(const Rig& rig,
                       const torch::Tensor& pose,   // [48] or [1, 48] axis-angle, float32 or float64
                       const torch::Tensor& shape,  // [10] or [1, 10]
                       const torch::Tensor& trans,  // [3] or [1, 3]
                       const LbsOptions& options = {});

}  // namespace handscs
