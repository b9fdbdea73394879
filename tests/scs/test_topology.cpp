// Static bone basis and smoothing kernel (paper §3.1.1).
#include "catch_torch.h"

#include <torch/types.h>

#include "core/error.h"
#include "scs/topology.h"

using handscs::ScsConfig;

TEST_CASE("topology: default E_s has its 20 bones") {
  const auto topology = handscs::make_static_topology(ScsConfig{});
  REQUIRE(topology.size() == 20);
  auto has = [&](int u, int v) {
    for (const auto& e : topology.edges)
      if (e[0] == u && e[1] == v) return true;
    return false;
  };
  CHECK_FALSE(has(0, 1));
  CHECK_FALSE(has(0, 4));
  CHECK_FALSE(has(0, 7));
  CHECK_FALSE(has(0, 10));
  CHECK(has(0, 13));  // the thumb keeps its wrist edge
  CHECK(has(13, 1));
  CHECK(has(1, 4));
  CHECK(has(4, 10));
  CHECK(has(10, 7));
  CHECK(has(15, 16));  // thumb distal -> thumb tip
  CHECK(has(9, 20));   // pinky distal -> pinky tip
}

TEST_CASE("topology: kernel is 0.5 on the diagonal, 0.25 for bones sharing a joint") {
  const auto topology = handscs::make_static_topology(ScsConfig{});
  const auto k = topology.kernel;
  CHECK(torch::allclose(k.diagonal(), torch::full({20}, 0.5f)));
  CHECK(torch::equal(k, k.t()));
  for (int64_t a = 0; a < topology.size(); ++a)
    for (int64_t b = 0; b < topology.size(); ++b) {
      if (a == b) continue;
      const auto& ea = topology.edges[a];
      const auto& eb = topology.edges[b];
      const bool share = ea[0] == eb[0] || ea[0] == eb[1] || ea[1] == eb[0] || ea[1] == eb[1];
      CHECK(k[a][b].item<float>() == (share ? 0.25f : 0.0f));
    }
  // Bone (1,2) (index proximal) touches (13,1), (1,4) and (2,3).
  int64_t index_proximal = -1;
  for (int64_t a = 0; a < topology.size(); ++a)
    if (topology.edges[a][0] == 1 && topology.edges[a][1] == 2) index_proximal = a;
  REQUIRE(index_proximal >= 0);
  CHECK(k[index_proximal].sum().item<float>() == Approx(0.5 + 3 * 0.25));
}

TEST_CASE("topology: bad edge lists are errors naming the key") {
  ScsConfig bad_joint;
  bad_joint.cross_edges = {{13, 21}};
  CHECK_THROWS_WITH(handscs::make_static_topology(bad_joint),
                    "model.scs.cross_edges: joint id 21 outside MANO21 [0, 20]");
  ScsConfig not_mano;
  not_mano.removed_edges = {{1, 4}};
  CHECK_THROWS_WITH(handscs::make_static_topology(not_mano),
                    "model.scs.removed_edges: (1, 4) is not a MANO edge");
  ScsConfig duplicate;
  duplicate.cross_edges = {{2, 1}};
  CHECK_THROWS_WITH(handscs::make_static_topology(duplicate),
                    "model.scs.cross_edges: (2, 1) is already a bone");
}
