// Non-rigid tissue the rig does not have, added to the ground truth only: displacements along the
// posed normal n_i of each vertex,
//   d_i = sum_j f_j [ bulge w_dorsal g_j - flexed w_palmar g_j - fold w_palmar exp(-s_j^2 / w^2) g'_j ]
//         - cup c w_palmar G_palm + thenar o G_thenar - contact_i,
// with f_j the flexion of finger joint j as a fraction of 90 degrees, g_j = exp(-|x - J_j|^2 / r_j^2)
// around the rest joint (r = 9, 7, 6 mm for MCP, PIP, DIP: the joints' sizes), s_j the rest offset
// along the bone (the crease line lies at the joint), c the palm's cupping (mean MCP flexion and
// opposition), o the thumb opposition, and contact_i = m (1 - g / R)^2 the flattening of a vertex
// facing another part of the hand (normals opposed, the other part in front) at distance g < R.
#pragma once

#include <array>
#include <vector>

#include "hand/rig.h"
#include "synth/articulation.h"
#include "synth/effects.h"
#include "synth/math.h"

namespace handscs {

struct TissueRig {
  std::vector<synth::Vec3> rest;         // template vertices (m)
  std::vector<int> part;                 // 0-4 finger (joint_order.h Finger), 5 palm
  std::vector<double> palmar;            // palmar-ness in [0, 1] relative to the owning bone
  std::array<synth::Vec3, 16> joints;    // rest joints
  std::array<std::array<synth::Vec3, 3>, 5> bone_dir;  // unit bone directions, [finger][joint]
  synth::Vec3 wrist, palm_long, palm_across, palm_normal;
  double palm_length = 0.09, palm_width = 0.08;
};

TissueRig make_tissue_rig(const Rig& rig, const HandAxes& axes);

struct TissueResult {
  std::vector<float> displacement;  // [V] along the normal (m), + outwards
  std::vector<float> contact;       // [V] contact flattening depth (m) >= 0
};

// Displacements of a posed mesh (vertices, unit normals [V * 3], world metres) for an articulation.
TissueResult tissue_displacement(const TissueRig& tissue, const SynthEffects& effects,
                                 const HandArticulation& articulation,
                                 const std::vector<float>& vertices,
                                 const std::vector<float>& normals);

// vertices += displacement * normal.
void apply_displacement(const TissueResult& result, const std::vector<float>& normals,
                        std::vector<float>& vertices);

}  // namespace handscs
