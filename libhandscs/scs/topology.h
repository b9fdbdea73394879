// Static bone topology on MANO21: E_s = (E_MANO \ E_removed) U E_cross, and the topology-aware
// smoothing kernel K (0.5 on the diagonal, 0.25 between bones sharing a joint, 0 otherwise).
#pragma once

#include <array>
#include <vector>

#include <torch/types.h>

#include "scs/scs_config.h"

namespace handscs {

struct BoneTopology {
  std::vector<std::array<int, 2>> edges;  // (u, v) MANO21 joint ids; the bone vector is j_v - j_u
  torch::Tensor u;       // [E] int64
  torch::Tensor v;       // [E] int64
  torch::Tensor kernel;  // [E, E] float32 smoothing kernel K

  int64_t size() const { return static_cast<int64_t>(edges.size()); }
};

// The 20 MANO edges: 15 parent->child (rig parents) and 5 distal->tip edges.
std::vector<std::array<int, 2>> mano21_edges();

// Builds E_s from the config; throws Error on an unknown joint id, a removed edge that is not in
// E_MANO, or a duplicated edge.
BoneTopology make_static_topology(const ScsConfig& config);

}  // namespace handscs
