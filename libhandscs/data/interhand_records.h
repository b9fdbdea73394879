// The InterHand2.6M layout as capture records: the capture's extract of data.json, camera.json,
// joint_3d.json and MANO_NeuralAnnot.json (through the annotation cache), filtered to the
// configured sequences, with cameras in metres and joints in MANO21 order.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "data/capture_config.h"
#include "data/capture_records.h"

namespace handscs {

// Throws Error naming the file and key for bad annotations, and the config key (`prefix`.capture,
// `prefix`.sequences) for a capture or sequence the files do not hold, listing what they do.
CaptureRecords read_interhand_records(const CaptureConfig& config, const std::string& prefix);

// One hand of a joint_3d.json frame (rows 0-20 right, 21-41 left, InterHand order, mm) as MANO21
// joints in metres and their valid flags.
void interhand_hand_joints(const InterHandJoints& entry, bool right, std::array<double, 63>& joints,
                           std::array<uint8_t, 21>& valid);

}  // namespace handscs
