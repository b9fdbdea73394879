// The metadata of a training checkpoint, checked after its checksum: the checksum says the bytes are
// those written, not that what was written makes sense (an edited file with its checksum recomputed,
// or a file of another program's making). Every field the trainer and the evaluator read is checked
// for type and range before anything uses it.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace handscs {

// The checkpoint format version this build writes and reads.
constexpr int kCheckpointVersion = 1;

// Checks format ("handscs-checkpoint"), version (kCheckpointVersion), config (an object holding
// train.iterations), iteration (an integer in [0, the stored train.iterations]), adam_steps (a
// non-negative integer), lr_scale (in (0, 1]) and, where present, skipped_steps and rollbacks
// (non-negative integers), running_psnr and elapsed_seconds (finite, elapsed_seconds >= 0) and
// capture_identity (data/capture_identity.h). A file named like a run's checkpoint (step_<8
// digits>.ckpt) must hold the step its name says. Throws Error naming `source` and the field.
void check_checkpoint_meta(const nlohmann::json& meta, const std::string& source);

}  // namespace handscs
