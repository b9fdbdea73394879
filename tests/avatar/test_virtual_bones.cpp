// Virtual-bone generator: attention rows sum to 1, t in [0, 1], endpoints follow the paper's formula.
#include "catch_torch.h"

#include <torch/types.h>

#include "scs/topology.h"
#include "scs/virtual_bones.h"

TEST_CASE("virtual bones: smoothed attention, interpolation factors and endpoints") {
  torch::manual_seed(0);
  handscs::ScsConfig config;
  const auto topology = handscs::make_static_topology(config);
  handscs::VirtualBoneGenerator generator(config, topology);
  const auto pose = torch::randn({48}) * 0.5;
  const auto joints = torch::randn({21, 3}) * 0.05;
  const auto bones = generator->forward(pose, joints, joints);
  REQUIRE(bones.start.sizes() == torch::IntArrayRef({16, 3}));
  CHECK(torch::allclose(bones.start_weights.sum(1), torch::ones({16}), 1e-6, 1e-6));
  CHECK(torch::allclose(bones.end_weights.sum(1), torch::ones({16}), 1e-6, 1e-6));
  CHECK(bones.start_weights.min().item<float>() >= 0);
  CHECK(bones.start_t.min().item<float>() >= 0);
  CHECK(bones.start_t.max().item<float>() <= 1);
  CHECK(bones.end_t.min().item<float>() >= 0);
  CHECK(bones.end_t.max().item<float>() <= 1);

  // The smoothed weights equal K softmax(w) / |K softmax(w)|_1 for some logits w: recover softmax by
  // solving K s = w~ * norm; K is invertible for the default topology, so check K^-1 w~ >= 0 and
  // that it sums to 1 / norm consistently (positivity is what the kernel formula guarantees).
  const auto kinv = torch::inverse(topology.kernel.to(torch::kFloat64));
  const auto s = bones.start_weights.to(torch::kFloat64).matmul(kinv.t());
  CHECK(s.min().item<double>() > -1e-5);

  // Endpoint formula without offsets: p = sum_b w_b [(1 - t_b) j_u + t_b j_v].
  config.endpoint_offsets = false;
  torch::manual_seed(0);
  handscs::VirtualBoneGenerator plain(config, topology);
  const auto b2 = plain->forward(pose, joints, joints);
  const auto ju = joints.index_select(0, topology.u);
  const auto jv = joints.index_select(0, topology.v);
  for (int64_t m = 0; m < 16; ++m) {
    auto expected = torch::zeros({3});
    for (int64_t e = 0; e < topology.size(); ++e) {
      const auto w = b2.start_weights[m][e];
      const auto t = b2.start_t[m][e];
      expected += w * ((1 - t) * ju[e] + t * jv[e]);
    }
    CHECK(torch::allclose(b2.start[m], expected, 1e-5, 1e-6));
  }
  // Without interpolation the factors are exactly 0.5 (bone midpoints).
  config.interpolation = false;
  handscs::VirtualBoneGenerator midpoints(config, topology);
  const auto b3 = midpoints->forward(pose, joints, joints);
  CHECK(torch::equal(b3.start_t, torch::full_like(b3.start_t, 0.5)));
}
