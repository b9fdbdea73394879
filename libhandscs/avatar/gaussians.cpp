#include "avatar/gaussians.h"

#include <torch/types.h>

#include "core/error.h"

namespace handscs {

std::vector<std::pair<std::string, torch::Tensor*>> GaussianState::learnable() {
  return {{"means", &means},
          {"log_scales", &log_scales},
          {"rotations", &rotations},
          {"colors", &colors},
          {"opacity_logits", &opacity_logits},
          {"embed_geometry", &embed_geometry},
          {"embed_appearance", &embed_appearance}};
}

std::vector<std::pair<std::string, torch::Tensor*>> GaussianState::all() {
  auto tensors = learnable();
  tensors.push_back({"skin_weights", &skin_weights});
  tensors.push_back({"vertex_ids", &vertex_ids});
  return tensors;
}

GaussianState GaussianState::select(const torch::Tensor& index) const {
  GaussianState out = *this;
  for (auto& [name, tensor] : out.all()) {
    const bool learn = tensor->requires_grad();
    *tensor = tensor->detach().index_select(0, index).clone();
    if (learn) tensor->set_requires_grad(true);
  }
  return out;
}

void GaussianState::append(const GaussianState& other) {
  GaussianState copy = other;
  auto mine = all();
  auto theirs = copy.all();
  for (size_t i = 0; i < mine.size(); ++i) {
    const bool learn = mine[i].second->requires_grad();
    *mine[i].second = torch::cat({mine[i].second->detach(), theirs[i].second->detach()}, 0);
    if (learn) mine[i].second->set_requires_grad(true);
  }
}

GaussianState init_gaussians_from_rig(const Rig& rig, const AvatarConfig& config) {
  require(config.opacity_init_min <= config.opacity_init_max,
          "avatar.opacity_init_min must not exceed avatar.opacity_init_max");
  torch::NoGradGuard no_grad;
  auto generator = at::detail::createCPUGenerator(static_cast<uint64_t>(config.seed));
  const auto verts = rig.v_template.to(torch::kFloat32);
  const int64_t n = verts.size(0);
  const auto f32 = torch::TensorOptions().dtype(torch::kFloat32);

  // Mean distance to the 3 nearest other vertices (3DGS initialises scales the same way).
  auto dist = torch::cdist(verts, verts);
  dist.fill_diagonal_(std::numeric_limits<float>::infinity());
  const int64_t k = std::min<int64_t>(3, std::max<int64_t>(n - 1, 1));
  auto nearest = std::get<0>(dist.topk(k, 1, /*largest=*/false)).mean(1).clamp_min(1e-5);

  GaussianState g;
  g.means = verts.clone();
  g.log_scales = torch::log(nearest * config.scale_init_factor).unsqueeze(1).repeat({1, 3});
  g.rotations = torch::zeros({n, 4}, f32);
  g.rotations.select(1, 0).fill_(1.0);
  g.colors = at::rand({n, 3}, generator, f32);
  const auto opacity = config.opacity_init_min +
                       (config.opacity_init_max - config.opacity_init_min) * at::rand({n}, generator, f32);
  g.opacity_logits = torch::log(opacity / (1 - opacity));
  const int64_t d = config.embeddings ? config.embedding_dim : 0;
  g.embed_geometry = at::normal(0.0, config.embedding_init_std, {n, d}, generator, f32);
  g.embed_appearance = at::normal(0.0, config.embedding_init_std, {n, d}, generator, f32);
  g.skin_weights = rig.weights.to(torch::kFloat32).clone();
  g.vertex_ids = torch::arange(n, torch::kInt64);
  for (auto& [name, tensor] : g.learnable()) tensor->set_requires_grad(true);
  return g;
}

}  // namespace handscs
