// avatar/covariance_chain.h under autograd: the one-op chain's values and gradients (written out by
// hand) against covariance_chain_ops + spd_from_raw differentiated by LibTorch, in double and float,
// with strided decoder outputs and transforms, a quaternion below the norm floor, and against
// central finite differences of a scalar loss.
#include "catch_torch.h"

#include <cmath>
#include <limits>

#include <torch/csrc/autograd/autograd.h>
#include <torch/types.h>

#include "avatar/covariance_chain.h"
#include "avatar/decoders.h"
#include "core/simd_level.h"
#include "tensor_bits.h"

namespace {

struct ChainInputs {
  torch::Tensor rotations, log_scales, geometry_out, fusion_out, transforms;  // leaves
  torch::Tensor geometry_raw() const { return handscs::spd_raw(geometry_out); }
  torch::Tensor fusion_raw() const { return handscs::spd_raw(fusion_out); }
  torch::Tensor linear() const { return transforms.slice(1, 0, 3).slice(2, 0, 3); }
  std::vector<torch::Tensor> leaves() const { return {rotations, log_scales, geometry_out, fusion_out, transforms}; }
};

ChainInputs random_inputs(int64_t n, torch::Dtype dtype) {
  const auto o = torch::TensorOptions().dtype(dtype);
  ChainInputs in;
  auto rotations = torch::randn({n, 4}, o);
  // |q|^2 ~ 1e-26, below the 1e-24 floor: the gradient goes through a fixed |q| (~1e12 in size).
  rotations[0] = torch::randn({4}, o) * 1e-13;
  rotations[1] *= 1e-3;
  in.rotations = rotations.requires_grad_(true);
  in.log_scales = (torch::randn({n, 3}, o) * 0.5 - 4.0).requires_grad_(true);
  // Decoder outputs as the decoders give them; the chain reads the strided 7-column slices.
  in.geometry_out = (torch::randn({n, 10}, o) * 0.3).requires_grad_(true);
  in.fusion_out = (torch::randn({n, 13}, o) * 0.3).requires_grad_(true);
  in.transforms = torch::randn({n, 4, 4}, o).requires_grad_(true);  // L is its strided 3x3 block
  return in;
}

std::vector<torch::Tensor> chain_outputs(const handscs::CovarianceChain& c) {
  return {c.dsigma, c.dsigma_f, c.canonical, c.posed_upper};
}

handscs::CovarianceChain reference(const ChainInputs& in) {
  return handscs::covariance_chain_ops(in.rotations, in.log_scales, handscs::spd_from_raw(in.geometry_raw()),
                                       handscs::spd_from_raw(in.fusion_raw()), in.linear());
}

handscs::CovarianceChain fused(const ChainInputs& in) {
  return handscs::covariance_chain(in.rotations, in.log_scales, in.geometry_raw(), in.fusion_raw(), in.linear());
}

torch::Tensor loss(const handscs::CovarianceChain& c, const std::vector<torch::Tensor>& cotangents) {
  const auto outs = chain_outputs(c);
  auto total = torch::zeros({}, outs[0].options());
  for (size_t k = 0; k < outs.size(); ++k) total = total + (outs[k] * cotangents[k]).sum();
  return total;
}

}  // namespace

TEST_CASE("covariance chain under autograd: values and gradients equal the LibTorch ops") {
  torch::manual_seed(3);
  for (const auto dtype : {torch::kDouble, torch::kFloat}) {
    const bool is_double = dtype == torch::kDouble;
    INFO((is_double ? "double" : "float"));
    const int64_t n = 515;  // more than two parallel tasks of at least 256 Gaussians
    const auto in = random_inputs(n, dtype);
    const auto mine = fused(in);
    const auto ref = reference(in);
    REQUIRE(mine.posed_upper.requires_grad());
    const auto outs = chain_outputs(mine), ref_outs = chain_outputs(ref);
    for (size_t k = 0; k < outs.size(); ++k) {
      // Relative to the output's largest value: L C L^T cancels, so small entries carry float
      // rounding of the large ones (the forward is the inference loop's, tested on its own).
      const double scale = ref_outs[k].abs().max().item<double>();
      CHECK((outs[k] - ref_outs[k]).abs().max().item<double>() <= (is_double ? 1e-13 : 1e-6) * scale);
    }

    std::vector<torch::Tensor> cotangents;
    for (const auto& o : ref_outs) cotangents.push_back(torch::randn_like(o));
    const auto grads = torch::autograd::grad({loss(mine, cotangents)}, in.leaves());
    const auto ref_grads = torch::autograd::grad({loss(ref, cotangents)}, in.leaves());
    const char* names[] = {"rotations", "log_scales", "geometry output", "fusion output", "transforms"};
    for (size_t k = 0; k < grads.size(); ++k) {
      INFO(names[k]);
      // Relative to each tensor's scale: the zero quaternion's gradient is ~1e12 (1 / the floor's root).
      const double scale = ref_grads[k].abs().max().item<double>();
      REQUIRE(scale > 0);
      const double diff = (grads[k] - ref_grads[k]).abs().max().item<double>();
      CHECK(diff <= (is_double ? 1e-11 : 2e-4) * scale);
      // Row by row too, so that a wrong small row is not hidden by the zero quaternion's large one.
      const auto rows = (grads[k] - ref_grads[k]).abs().flatten(1).amax(1);
      const auto row_scale = ref_grads[k].abs().flatten(1).amax(1);
      CHECK((rows <= (is_double ? 1e-10 : 1e-3) * (row_scale + 1e-6)).all().item<bool>());
      // The floored quaternion's row is not trivially zero (so its branch is exercised).
      if (k == 0) CHECK(row_scale[0].item<double>() > 1e6);
    }
  }
}

TEST_CASE("covariance chain: the AVX-512 pass gives the plain loop's values and gradients bit for bit") {
  if (handscs::detected_simd_level() != handscs::SimdLevel::avx512) {
    WARN("no AVX-512 here: the 16-lane pass is not checked");
    return;
  }
  torch::manual_seed(5);
  // 515 rows: split between the threads (at::parallel_for), e.g. 258 + 257 on two, so each part
  // has full 16-lane blocks and a tail; 512 rows on two threads: no tail; 7 rows: a tail only.
  for (const int64_t n : {515, 512, 7}) {
    INFO("n = " << n);
    const auto in = random_inputs(n, torch::kFloat);
    {
      torch::NoGradGuard no_grad;
      // Overflowing and non-finite values in a few rows: the lanes carry them as the loop does.
      in.log_scales[2][1] = 100.0;
      in.geometry_out[3][4] = std::nan("");
      in.fusion_out[4][0] = std::numeric_limits<float>::infinity();
    }
    std::vector<torch::Tensor> cotangents;
    for (const auto& o : chain_outputs(reference(in))) cotangents.push_back(torch::randn_like(o));
    std::vector<torch::Tensor> values[2], grads[2];
    for (const auto level : {handscs::SimdLevel::generic, handscs::SimdLevel::avx512}) {
      handscs::set_simd_level(level);
      const int k = level == handscs::SimdLevel::avx512;
      {
        torch::NoGradGuard no_grad;  // the inference loop
        values[k] = chain_outputs(fused(in));
      }
      const auto under_autograd = fused(in);
      const auto outs = chain_outputs(under_autograd);
      for (size_t m = 0; m < outs.size(); ++m) CHECK(handscs_test::same_bits(outs[m], values[k][m]));
      grads[k] = torch::autograd::grad({loss(under_autograd, cotangents)}, in.leaves());
    }
    handscs::set_simd_level(handscs::detected_simd_level());
    for (size_t m = 0; m < values[0].size(); ++m) CHECK(handscs_test::same_bits(values[0][m], values[1][m]));
    const char* names[] = {"rotations", "log_scales", "geometry output", "fusion output", "transforms"};
    for (size_t m = 0; m < grads[0].size(); ++m) {
      INFO(names[m]);
      CHECK(handscs_test::same_bits(grads[0][m], grads[1][m]));
    }
    // The non-finite rows reach the outputs (so the comparison covers them).
    CHECK_FALSE(torch::isfinite(values[0][0][3]).all().item<bool>());
  }
}

TEST_CASE("covariance chain under autograd: central finite differences in double") {
  torch::manual_seed(11);
  const auto in = random_inputs(6, torch::kDouble);
  std::vector<torch::Tensor> cotangents;
  for (const auto& o : chain_outputs(reference(in))) cotangents.push_back(torch::randn_like(o));
  const auto grads = torch::autograd::grad({loss(fused(in), cotangents)}, in.leaves());
  const double h = 1e-6;
  const auto leaves = in.leaves();
  for (size_t k = 0; k < grads.size(); ++k) {
    const auto flat = leaves[k].detach().view({-1});
    // Rows 2.. only: row 0's quaternion sits on the floor, where the derivative is one-sided.
    for (int64_t i = flat.numel() / 3; i < flat.numel(); i += 5) {
      const double saved = flat[i].item<double>();
      double value[2];
      for (int side = 0; side < 2; ++side) {
        flat[i] = saved + (side == 0 ? h : -h);
        torch::NoGradGuard no_grad;
        value[side] = loss(fused(in), cotangents).item<double>();
      }
      flat[i] = saved;
      const double numeric = (value[0] - value[1]) / (2 * h);
      const double analytic = grads[k].view({-1})[i].item<double>();
      INFO("leaf " << k << " element " << i);
      CHECK(analytic == Approx(numeric).epsilon(1e-5).margin(1e-7));
    }
  }
}

TEST_CASE("covariance chain under autograd: unused outputs and broadcast gradients") {
  torch::manual_seed(4);
  const auto in = random_inputs(300, torch::kDouble);
  // Only the posed covariances used, through a sum (a stride-0 gradient); the other three outputs
  // get zero gradients.
  const auto grads = torch::autograd::grad({fused(in).posed_upper.sum()}, in.leaves());
  const auto ref_grads = torch::autograd::grad({reference(in).posed_upper.sum()}, in.leaves());
  for (size_t k = 0; k < grads.size(); ++k) {
    INFO("leaf " << k);
    const auto rows = (grads[k] - ref_grads[k]).abs().flatten(1).amax(1);
    const auto row_scale = ref_grads[k].abs().flatten(1).amax(1);
    CHECK((rows <= 1e-10 * (row_scale + 1e-6)).all().item<bool>());
  }
}

TEST_CASE("covariance chain: inputs of the wrong shape or dtype are refused with their sizes") {
  const auto in = random_inputs(4, torch::kFloat);
  torch::NoGradGuard no_grad;
  CHECK_THROWS_WITH(handscs::covariance_chain(in.rotations.slice(0, 0, 3), in.log_scales, in.geometry_raw(),
                                              in.fusion_raw(), in.linear()),
                    Catch::Contains("covariance_chain: log_scales must be [3, 3], got [4, 3]"));
  CHECK_THROWS_WITH(handscs::covariance_chain(in.rotations, in.log_scales, in.geometry_out, in.fusion_raw(),
                                              in.linear()),
                    Catch::Contains("geometry_raw"));
  CHECK_THROWS_WITH(handscs::covariance_chain(in.rotations, in.log_scales, in.geometry_raw(), in.fusion_raw(),
                                              in.transforms),
                    Catch::Contains("linear"));
  CHECK_THROWS_WITH(handscs::covariance_chain(in.rotations.to(torch::kDouble), in.log_scales, in.geometry_raw(),
                                              in.fusion_raw(), in.linear()),
                    Catch::Contains("dtype"));
}
