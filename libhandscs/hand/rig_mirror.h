// Mirror image of a rig through the plane x = 0 (right hand <-> left hand, as MANO_LEFT mirrors
// MANO_RIGHT): x -> -x on vertices and on the x rows of the blend shapes, axis-angle (a, b, c) ->
// (a, -b, -c), pose blend shapes P'[v, c, (j, r, s)] = m_c m_r m_s P[v, c, (j, r, s)] with
// m = (-1, 1, 1), faces re-wound so they stay counter-clockwise from outside.
#pragma once

#include "hand/rig.h"

namespace handscs {

Rig mirror_rig(const Rig& rig);

}  // namespace handscs
