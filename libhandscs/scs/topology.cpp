#include "scs/topology.h"

#include <algorithm>
#include <string>

#include "core/error.h"
#include "hand/rig.h"

namespace handscs {

namespace {
// MANO rig parents (docs/RIG_FORMAT.md) and the distal joint of each finger with its MANO21 tip id.
constexpr std::array<int, 16> kParents = {-1, 0, 1, 2, 0, 4, 5, 0, 7, 8, 0, 10, 11, 0, 13, 14};
constexpr std::array<std::array<int, 2>, 5> kDistalToTip = {
    {{15, 16}, {3, 17}, {6, 18}, {12, 19}, {9, 20}}};

std::string edge_name(const std::array<int, 2>& e) {
  return "(" + std::to_string(e[0]) + ", " + std::to_string(e[1]) + ")";
}
}  // namespace

std::vector<std::array<int, 2>> mano21_edges() {
  std::vector<std::array<int, 2>> edges;
  for (int child = 1; child < 16; ++child) edges.push_back({kParents[child], child});
  for (const auto& e : kDistalToTip) edges.push_back(e);
  return edges;
}

BoneTopology make_static_topology(const ScsConfig& config) {
  auto same = [](const std::array<int, 2>& a, const std::array<int, 2>& b) {
    return (a[0] == b[0] && a[1] == b[1]) || (a[0] == b[1] && a[1] == b[0]);
  };
  auto contains = [&](const std::vector<std::array<int, 2>>& list, const std::array<int, 2>& e) {
    return std::any_of(list.begin(), list.end(), [&](const auto& x) { return same(x, e); });
  };
  for (const auto& e : config.removed_edges)
    for (int j : e)
      require(j >= 0 && j < kJoints21, "model.scs.removed_edges: joint id " + std::to_string(j) +
                                           " outside MANO21 [0, 20]");
  for (const auto& e : config.cross_edges)
    for (int j : e)
      require(j >= 0 && j < kJoints21, "model.scs.cross_edges: joint id " + std::to_string(j) +
                                           " outside MANO21 [0, 20]");

  const auto mano = mano21_edges();
  for (const auto& e : config.removed_edges)
    require(contains(mano, e), "model.scs.removed_edges: " + edge_name(e) + " is not a MANO edge");

  BoneTopology topology;
  for (const auto& e : mano)
    if (!contains(config.removed_edges, e)) topology.edges.push_back(e);
  for (const auto& e : config.cross_edges) {
    require(e[0] != e[1], "model.scs.cross_edges: " + edge_name(e) + " has zero length by construction");
    require(!contains(topology.edges, e), "model.scs.cross_edges: " + edge_name(e) + " is already a bone");
    topology.edges.push_back(e);
  }

  const int64_t count = topology.size();
  std::vector<int64_t> u(count), v(count);
  for (int64_t i = 0; i < count; ++i) {
    u[i] = topology.edges[i][0];
    v[i] = topology.edges[i][1];
  }
  topology.u = torch::tensor(u, torch::kInt64);
  topology.v = torch::tensor(v, torch::kInt64);

  // Paper §3.1.1: weight 0.5 for a bone itself and 0.25 for each directly connected bone.
  topology.kernel = torch::zeros({count, count}, torch::kFloat32);
  auto k = topology.kernel.accessor<float, 2>();
  for (int64_t a = 0; a < count; ++a) {
    for (int64_t b = 0; b < count; ++b) {
      if (a == b) {
        k[a][b] = 0.5f;
        continue;
      }
      const auto& ea = topology.edges[a];
      const auto& eb = topology.edges[b];
      const bool share = ea[0] == eb[0] || ea[0] == eb[1] || ea[1] == eb[0] || ea[1] == eb[1];
      if (share) k[a][b] = 0.25f;
    }
  }
  return topology;
}

}  // namespace handscs
