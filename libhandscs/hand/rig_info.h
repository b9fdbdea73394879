// Human-readable summary of a rig (sizes, handedness, bounding box, joint positions) and a plain
// Wavefront OBJ export of its template mesh, for `handscs-rig --info` and for viewing in any tool.
#pragma once

#include <string>

#include "hand/rig.h"

namespace handscs {

// Multi-line text: name, handedness, vertex/face/joint counts, bounding box and extent (metres),
// wrist-to-middle-tip length, region label counts, rest joints (MANO21).
std::string describe_rig(const Rig& rig);

// Writes the zero-pose template (v_template, faces) as OBJ, atomically.
void write_rig_obj(const Rig& rig, const std::string& path);

}  // namespace handscs
