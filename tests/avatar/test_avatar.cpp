// The avatar forward: zero gates equal plain LBS, gradients reach every parameter group and match
// finite differences in double precision, ablation switches, and stability on extreme input.
#include "catch_torch.h"

#include <cmath>
#include <functional>

#include <torch/csrc/autograd/autograd.h>
#include <torch/types.h>

#include "avatar/avatar.h"
#include "core/error.h"
#include "hand/lbs.h"
#include "hand/lbs_one_pose.h"
#include "scs/descriptor.h"
#include "small_avatar.h"
#include "render/rotation.h"

namespace {

torch::Tensor small_pose(uint64_t seed) {
  auto gen = at::detail::createCPUGenerator(seed);
  return at::normal(0.0, 0.2, {48}, gen, torch::kFloat32);
}

}  // namespace

TEST_CASE("avatar: with zero gates the render equals LBS of the canonical Gaussians") {
  handscs::AvatarConfig config;
  handscs::Avatar avatar(config, handscs::load_rig_source("builtin"));
  const auto pose = small_pose(1);
  const auto shape = torch::randn({10}) * 0.5;
  const auto trans = torch::tensor({0.01f, -0.02f, 0.03f});
  const auto camera = handscs_test::hand_view_camera(96, 64);
  handscs::RasterSettings settings;
  const auto out = avatar.forward(pose, shape, trans, camera, settings);

  // Plain LBS by hand: per-Gaussian T from the rig's skinning weights, Sigma = R S S R^T. No
  // gradient reaches the pose, so the avatar skins with the plain loops (double, rounded once).
  auto& g = avatar.gaussians();
  const auto l = handscs::lbs_one_pose(avatar.rig(), pose.view({1, 48}), shape.view({1, 10}), trans.view({1, 3}));
  const auto t = g.skin_weights.matmul(l.joint_transforms[0].reshape({16, 16})).view({-1, 4, 4});
  const auto lin = t.slice(1, 0, 3).slice(2, 0, 3);
  const auto x = g.means + l.blend_offsets[0];
  const auto means = lin.matmul(x.unsqueeze(2)).squeeze(2) + t.slice(1, 0, 3).select(2, 3);
  const auto rot = handscs::quaternion_to_matrix(g.rotations);
  const auto scaled = rot * torch::exp(g.log_scales).unsqueeze(1);
  const auto cov = lin.matmul(scaled.matmul(scaled.transpose(1, 2))).matmul(lin.transpose(1, 2));
  const auto expected = handscs::rasterize_gaussians(
      means, handscs::symmetric_upper(cov), g.colors, torch::sigmoid(g.opacity_logits), camera,
      settings);
  CHECK(torch::equal(out.state.lbs.joint_transforms, l.joint_transforms));  // the loops' bits
  CHECK(torch::equal(out.state.posed.means, means));
  // The covariances come from the one-pass 3x3 chain (avatar/covariance_chain.h), whose products
  // round in another order than these matmuls: equal to float rounding of their scale.
  const auto upper = handscs::symmetric_upper(cov);
  // Per Gaussian, against its own covariance's scale.
  const auto diff = (out.state.posed.covariances - upper).abs().amax(1);
  CHECK((diff <= 1e-6 * upper.abs().amax(1)).all().item<bool>());
  CHECK((out.render.rgb - expected.rgb).abs().max().item<double>() <= 1e-5);
  CHECK((out.render.alpha - expected.alpha).abs().max().item<double>() <= 1e-5);
  CHECK(out.render.alpha.max().item<float>() > 0.5f);  // the hand is in view

  // A pose that needs a gradient (pose refinement) is skinned by lbs() in LibTorch ops, and the
  // gradient reaches it.
  const auto learnt_pose = pose.clone().requires_grad_(true);
  const auto refined = avatar.pose(learnt_pose, shape, trans);
  const auto l_graph =
      handscs::lbs(avatar.rig(), learnt_pose.view({1, 48}), shape.view({1, 10}), trans.view({1, 3}));
  CHECK(torch::equal(refined.lbs.joints, l_graph.joints));
  refined.posed.means.sum().backward();
  REQUIRE(learnt_pose.grad().defined());
  CHECK(learnt_pose.grad().abs().sum().item<double>() > 0);
}

TEST_CASE("avatar: gradients reach every parameter group") {
  handscs::AvatarConfig config;
  handscs::Avatar avatar(config, handscs::load_rig_source("builtin"));
  // Open the gates a little so the decoder weights receive gradient too, and make the Gaussians
  // anisotropic (an isotropic Gaussian's rotation does not change it: zero gradient, rightly).
  {
    torch::NoGradGuard no_grad;
    for (auto& p : avatar.decoders()->parameters())
      if (p.numel() == 1) p.fill_(0.1);
    avatar.gaussians().log_scales.add_(torch::randn_like(avatar.gaussians().log_scales) * 0.3);
  }
  const auto out = avatar.forward(small_pose(2), torch::zeros({10}), torch::zeros({3}),
                                  handscs_test::hand_view_camera(64, 48), {}, {}, true);
  const auto loss = out.render.rgb.mean() + out.render.alpha.mean();
  loss.backward();
  for (auto& [name, tensor] : avatar.gaussians().learnable()) {
    INFO(name);
    REQUIRE(tensor->grad().defined());
    CHECK(tensor->grad().abs().sum().item<double>() > 0);
    CHECK(torch::isfinite(tensor->grad()).all().item<bool>());
  }
  for (auto& [group, params] : avatar.network_parameter_groups()) {
    double total = 0;
    for (auto& p : params) {
      REQUIRE(p.grad().defined());
      CHECK(torch::isfinite(p.grad()).all().item<bool>());
      total += p.grad().abs().sum().item<double>();
    }
    INFO(group);
    CHECK(total > 0);
  }
}

TEST_CASE("avatar: gradients match finite differences in double precision") {
  handscs::Avatar avatar = handscs_test::small_double_avatar();
  {
    torch::NoGradGuard no_grad;
    avatar.gaussians().log_scales.add_(torch::randn_like(avatar.gaussians().log_scales) * 0.3);
  }
  const auto pose = small_pose(4).to(torch::kFloat64);
  const auto camera = handscs_test::hand_view_camera(40, 30);
  auto gen = at::detail::createCPUGenerator(9);
  const int64_t n = avatar.gaussians().size();
  const auto w_rgb = at::rand({30, 40, 3}, gen, torch::kFloat64);
  const auto w_alpha = at::rand({30, 40}, gen, torch::kFloat64);
  const auto w_means = at::rand({n, 3}, gen, torch::kFloat64);
  const auto w_cov = at::rand({n, 6}, gen, torch::kFloat64) * 1e4;  // covariances are ~1e-5 m^2
  const auto w_colors = at::rand({n, 3}, gen, torch::kFloat64);
  const auto w_opacity = at::rand({n}, gen, torch::kFloat64);
  const auto w_descriptor = at::rand({n, avatar.descriptor_dim()}, gen, torch::kFloat64);
  // Smooth objective: every output of the posing stage (no rasterizer thresholds involved).
  auto smooth = [&]() {
    const auto s = avatar.pose(pose, torch::zeros({10}), torch::zeros({3}), true);
    return (s.posed.means * w_means).sum() + (s.posed.covariances * w_cov).sum() +
           (s.posed.colors * w_colors).sum() + (s.posed.opacities * w_opacity).sum() +
           (s.descriptor * w_descriptor).sum();
  };
  // Through the rasterizer: only parameters that move one Gaussian each (a shared parameter such as a
  // gate moves all of them at once and a finite step crosses some alpha threshold).
  auto rendered = [&]() {
    const auto out = avatar.forward(pose, torch::zeros({10}), torch::zeros({3}), camera, {});
    return (out.render.rgb * w_rgb).sum() + (out.render.alpha * w_alpha).sum();
  };
  auto check = [&](const std::function<torch::Tensor()>& objective, bool networks, const char* kind) {
    for (auto& [name, tensor] : avatar.gaussians().learnable())
      if (tensor->grad().defined()) tensor->mutable_grad().zero_();
    for (auto& [group, params] : avatar.network_parameter_groups())
      for (auto& p : params)
        if (p.grad().defined()) p.mutable_grad().zero_();
    objective().backward();
    std::vector<std::pair<std::string, torch::Tensor>> probes;
    for (auto& [name, tensor] : avatar.gaussians().learnable()) probes.push_back({name, *tensor});
    if (networks)
      for (auto& [group, params] : avatar.network_parameter_groups())
        for (auto& p : params) probes.push_back({group, p});
    const double h = 1e-6;
    for (auto& [name, tensor] : probes) {
      const auto grad = tensor.grad().reshape({-1});
      auto flat = tensor.detach().view({-1});
      const int64_t top = grad.abs().argmax().item<int64_t>();
      for (int64_t index : {top, (top * 7 + 3) % flat.numel()}) {
        const double original = flat[index].item<double>();
        double plus, minus;
        {
          torch::NoGradGuard no_grad;
          flat[index] = original + h;
          plus = objective().item<double>();
          flat[index] = original - h;
          minus = objective().item<double>();
          flat[index] = original;
        }
        const double numeric = (plus - minus) / (2 * h);
        const double analytic = grad[index].item<double>();
        INFO(kind << " " << name << "[" << index << "]: analytic " << analytic << ", numeric "
                  << numeric);
        // Relative 1e-4; absolute 1e-6 = round-off of a central difference (step 1e-6) of an
        // objective of magnitude ~1e3 in double precision.
        CHECK(analytic == Approx(numeric).epsilon(1e-4).margin(1e-6));
      }
    }
  };
  check(smooth, true, "posed Gaussians and P:");
  check(rendered, false, "render:");
}

TEST_CASE("avatar: every ablation switch builds and renders finite images") {
  struct Case {
    const char* name;
    std::function<void(handscs::AvatarConfig&)> apply;
  };
  const std::vector<Case> cases = {
      {"no SCS", [](auto& c) { c.scs.enabled = false; }},
      {"no static bones", [](auto& c) { c.scs.static_bones = false; }},
      {"no virtual bones", [](auto& c) { c.scs.virtual_bones = 0; }},
      {"no embeddings", [](auto& c) { c.embeddings = false; }},
      {"posed virtual bones", [](auto& c) { c.scs.virtual_space = handscs::ScsConfig::VirtualSpace::posed; }},
      {"no t", [](auto& c) { c.scs.interpolation = false; }},
      {"no dp/dq", [](auto& c) { c.scs.endpoint_offsets = false; }},
  };
  for (const auto& c : cases) {
    handscs::AvatarConfig config;
    c.apply(config);
    handscs::Avatar avatar(config, handscs::load_rig_source("builtin"));
    const auto out = avatar.forward(small_pose(5), torch::zeros({10}), torch::zeros({3}),
                                    handscs_test::hand_view_camera(48, 32), {}, {}, true);
    INFO(c.name);
    CHECK(torch::isfinite(out.render.rgb).all().item<bool>());
    CHECK(out.state.descriptor.size(1) == avatar.descriptor_dim());
  }
  handscs::AvatarConfig none;
  none.scs.static_bones = false;
  none.scs.virtual_bones = 0;
  handscs::Avatar empty_basis(none, handscs::load_rig_source("builtin"));
  CHECK(empty_basis.descriptor_dim() == 0);
}

TEST_CASE("avatar: extreme poses, Gaussians on joints and bad input") {
  handscs::AvatarConfig config;
  handscs::Avatar avatar(config, handscs::load_rig_source("builtin"));
  {
    torch::NoGradGuard no_grad;
    for (auto& p : avatar.decoders()->parameters())
      if (p.numel() == 1) p.fill_(0.1);
    // Put the first 21 Gaussians exactly on the canonical joints.
    const auto l = handscs::lbs(avatar.rig(), torch::zeros({1, 48}), torch::zeros({1, 10}),
                                torch::zeros({1, 3}), {true});
    avatar.gaussians().means.slice(0, 0, 21).copy_(l.rest_joints[0]);
  }
  for (double angle : {M_PI, -M_PI}) {
    auto pose = torch::zeros({48});
    for (int j = 0; j < 16; ++j) pose[3 * j + (j % 3)] = angle;  // every joint at +-pi
    const auto out = avatar.forward(pose, torch::zeros({10}), torch::zeros({3}), handscs_test::hand_view_camera(48, 32),
                                    {}, {}, true);
    (out.render.rgb.sum() + out.state.descriptor.sum()).backward();
    CHECK(torch::isfinite(out.render.rgb).all().item<bool>());
    CHECK(torch::isfinite(out.state.descriptor).all().item<bool>());
    for (auto& [name, tensor] : avatar.gaussians().learnable()) {
      INFO(name);
      CHECK(torch::isfinite(tensor->grad()).all().item<bool>());
      tensor->mutable_grad().zero_();
    }
  }
  auto nan_pose = torch::zeros({48});
  nan_pose[7] = NAN;
  CHECK_THROWS_WITH(avatar.forward(nan_pose, torch::zeros({10}), torch::zeros({3}),
                                   handscs_test::hand_view_camera(48, 32), {}),
                    "avatar: pose contains NaN or Inf");
  CHECK_THROWS_WITH(avatar.forward(torch::zeros({47}), torch::zeros({10}), torch::zeros({3}),
                                   handscs_test::hand_view_camera(48, 32), {}),
                    "avatar: pose must have 48 values, got 47");
}

TEST_CASE("avatar: virtual bones and Gaussian centres share the shaped canonical space") {
  // The generator builds bones from the shaped rest joints; the descriptor must measure the
  // Gaussians in that same space. Reference: the rig vertices of the shaped hand at rest, from
  // plain LBS with a zero pose (flat hand) and zero translation, where the Gaussians start.
  handscs::AvatarConfig config;
  config.scs.static_bones = false;  // the descriptor is the virtual part alone
  config.scs.virtual_bones = 8;
  config.scs.virtual_space = handscs::ScsConfig::VirtualSpace::canonical;
  handscs::Avatar avatar(config, handscs::load_rig_source("builtin"));
  const auto& g = avatar.gaussians();
  const auto& rig = avatar.rig();
  REQUIRE(torch::allclose(g.means, rig.v_template.to(torch::kFloat32).index_select(0, g.vertex_ids)));

  const auto shape = torch::linspace(-2.0, 2.0, 10);  // a hand far from the template
  const auto state = avatar.pose(small_pose(3), shape, torch::zeros({3}));
  const auto rest = handscs::lbs(rig, torch::zeros({1, 48}), shape.view({1, 10}), torch::zeros({1, 3}),
                                 handscs::LbsOptions{/*flat_hand_mean=*/true});
  const auto shaped_centres = rest.vertices[0].index_select(0, g.vertex_ids);
  const auto expected = handscs::virtual_descriptor(shaped_centres, state.virtual_bones.start,
                                                    state.virtual_bones.end, config.scs.norm_eps);
  REQUIRE(state.descriptor.sizes() == expected.sizes());
  CHECK(torch::allclose(state.descriptor, expected, 1e-5, 1e-6));
  // The unshaped template would be measurably off (the old behaviour): millimetres, not rounding.
  const auto template_only = handscs::virtual_descriptor(g.means, state.virtual_bones.start,
                                                         state.virtual_bones.end, config.scs.norm_eps);
  CHECK((template_only - expected).abs().max().item<double>() > 1e-4);
}

TEST_CASE("avatar: scs.input_norm rest gives the decoders P at the embeddings' scale") {
  handscs::AvatarConfig config;
  config.scs.input_norm = handscs::ScsConfig::InputNorm::rest;
  handscs::Avatar avatar(config, handscs::load_rig_source("builtin"));
  const auto zero_pose = torch::zeros({48});
  const auto rest = avatar.pose(zero_pose, torch::zeros({10}), torch::zeros({3}), true);
  const auto view = avatar.decoder_view(rest.descriptor);
  REQUIRE(view.sizes() == rest.descriptor.sizes());
  // Invariant: at the zero pose, over the initial Gaussians, every dimension has mean 0 and the
  // embeddings' initial std (every dimension of the built-in hand varies well above the floor).
  CHECK(rest.descriptor.std(0).min().item<double>() > 1e-3);
  CHECK(view.mean(0).abs().max().item<double>() < 1e-6);
  const auto std = view.std(0);
  CHECK(std.min().item<double>() == Approx(config.embedding_init_std).epsilon(1e-4));
  CHECK(std.max().item<double>() == Approx(config.embedding_init_std).epsilon(1e-4));
  // The statistics depend on the config and rig only: a second avatar (as on loading a
  // checkpoint) views P bit for bit the same.
  handscs::Avatar again(config, handscs::load_rig_source("builtin"));
  const auto posed = avatar.pose(small_pose(5), torch::zeros({10}), torch::zeros({3}), true);
  CHECK(torch::equal(again.decoder_view(posed.descriptor), avatar.decoder_view(posed.descriptor)));
  // The default leaves P as it is.
  handscs::Avatar plain(handscs::AvatarConfig{}, handscs::load_rig_source("builtin"));
  CHECK(torch::equal(plain.decoder_view(posed.descriptor), posed.descriptor));
}

TEST_CASE("avatar: scs.detach_means keeps P's gradient from the means, not from the generator") {
  torch::Tensor first;  // P without detaching: detaching changes no value
  for (const bool detach : {false, true}) {
    INFO("detach_means " << detach);
    handscs::AvatarConfig config;
    config.scs.detach_means = detach;
    handscs::Avatar avatar(config, handscs::load_rig_source("builtin"));
    const auto state = avatar.pose(small_pose(6), torch::zeros({10}), torch::zeros({3}), true);
    if (detach)
      CHECK(torch::equal(state.descriptor, first));
    else
      first = state.descriptor.detach();
    // A fixed random weighting of P, so no gradient cancels by symmetry.
    const auto weights = torch::randn(state.descriptor.sizes(),
                                      at::detail::createCPUGenerator(7), torch::kFloat32);
    const auto loss = (state.descriptor * weights).sum();
    std::vector<torch::Tensor> inputs = {avatar.gaussians().means};
    for (const auto& p : avatar.generator()->parameters()) inputs.push_back(p);
    const auto grads = torch::autograd::grad({loss}, inputs, {}, false, false, true);
    const double means_grad = grads[0].defined() ? grads[0].abs().sum().item<double>() : 0.0;
    double generator_grad = 0;
    for (size_t i = 1; i < grads.size(); ++i)
      if (grads[i].defined()) generator_grad += grads[i].abs().sum().item<double>();
    CHECK(generator_grad > 0);
    if (detach)
      CHECK(means_grad == 0);
    else
      CHECK(means_grad > 0);
  }
}
