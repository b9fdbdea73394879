// pose_source = joints: each frame's MANO parameters fitted to InterHand2.6M's joint_3d.json
// (hand/keypoint_fit.h) instead of read from MANO_NeuralAnnot, one shape for the capture. The fits
// are cached beside the annotation cache, keyed by the joint file, the rig and the fit settings,
// so the second open costs a file read.
#pragma once

#include <cstdint>
#include <map>
#include <string>

#include "data/capture_config.h"
#include "data/capture_records.h"
#include "data/interhand_annotations.h"

namespace handscs {

// One RecordFrame per frame of `joints` with the configured hand fitted (frames whose hand_type
// excludes that hand, or with fewer than kMinFitKeypoints valid joints, have no hand). A hand whose
// mean residual exceeds c.poor_joint_fit_mm carries its fit_problem.
std::map<int64_t, RecordFrame> fit_joint_frames(const std::map<int64_t, InterHandJoints>& joints,
                                                const std::string& joint_3d_json, const CaptureConfig& c);

}  // namespace handscs
