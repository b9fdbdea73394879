// The forearm of a synthetic capture: an elliptic truncated cone continuing the hand's wrist out of
// the frame (it is not part of the rig, so the MANO-derived masks cut it off, as on real data).
// Its cross-section at the wrist is measured from the rig's wrist-end vertices; it turns with the
// forearm's pronation only (wrist flexion and deviation bend the hand, not the forearm).
#pragma once

#include <cstdint>
#include <vector>

#include "hand/rig.h"
#include "synth/articulation.h"
#include "synth/math.h"

namespace handscs {

struct ForearmMesh {
  std::vector<float> rest;      // [V * 3] rest-frame vertices (m), also the texture coordinates
  std::vector<int64_t> faces;   // [F * 3], vertex ids local to the forearm, outward winding
  synth::Vec3 pivot;            // the rest wrist joint: the forearm turns about it
};

ForearmMesh make_forearm(const Rig& rig, const HandAxes& axes);

// World vertices [V * 3]: R(long axis, pronation) (x - pivot) + wrist_world.
std::vector<float> pose_forearm(const ForearmMesh& forearm, const HandAxes& axes,
                                const HandArticulation& articulation,
                                const synth::Vec3& wrist_world);

}  // namespace handscs
