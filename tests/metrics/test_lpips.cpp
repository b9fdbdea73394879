// LPIPS: the published LPIPS-alex values of the shared pairs, an independent layer-list reference
// (torchvision indices) for alex and vgg, input ranges, the normalisation guard, and gradients.
#include "metrics_test_utils.h"  // first: brings Catch2 in after torch (see there)

#include <fstream>

#include <torch/csrc/api/include/torch/serialize.h>

#include "metrics/lpips.h"

using Catch::Matchers::WithinAbs;

namespace {

// Reference LPIPS from torchvision's `features` layer list: 'C' conv (index i of the original
// Sequential) + ReLU, 'P' max-pool; `taps` are the indices whose ReLU output LPIPS uses.
struct Layer {
  char kind;
  int index;
  int stride, padding, pool;
};

torch::Tensor lpips_reference(const handscs::TensorDict& w, const std::vector<Layer>& layers,
                              const std::vector<int>& taps, const torch::Tensor& x0,
                              const torch::Tensor& y0) {
  auto dt = x0.scalar_type();
  auto shift = torch::tensor({-0.030, -0.088, -0.188}, torch::kDouble).view({1, 3, 1, 1}).to(torch::kFloat).to(dt);
  auto scale = torch::tensor({0.458, 0.448, 0.450}, torch::kDouble).view({1, 3, 1, 1}).to(torch::kFloat).to(dt);
  auto run = [&](torch::Tensor h) {
    h = ((h * 2 - 1) - shift) / scale;
    std::vector<torch::Tensor> out;
    int slice = 0;
    for (const auto& layer : layers) {
      if (layer.kind == 'P') {
        h = at::max_pool2d(h, {layer.pool, layer.pool}, {layer.stride, layer.stride});
        continue;
      }
      // Find the slice this index lives in: slices end at the tap indices.
      while (layer.index > taps[slice]) ++slice;
      const std::string key = "net.slice" + std::to_string(slice + 1) + "." + std::to_string(layer.index);
      h = at::relu(at::conv2d(h, w.at(key + ".weight").to(dt), w.at(key + ".bias").to(dt), layer.stride,
                              layer.padding));
      if (std::find(taps.begin(), taps.end(), layer.index + 1) != taps.end()) out.push_back(h);
    }
    return out;
  };
  auto fx = run(x0), fy = run(y0);
  torch::Tensor total = torch::zeros({x0.size(0)}, x0.options());
  for (size_t t = 0; t < fx.size(); ++t) {
    auto nx = fx[t] / (fx[t].square().sum(1, true).sqrt() + 1e-10);
    auto ny = fy[t] / (fy[t].square().sum(1, true).sqrt() + 1e-10);
    auto lin = w.at("lin" + std::to_string(t) + ".model.1.weight").to(dt);
    total = total + ((nx - ny).square() * lin).sum(1).mean({1, 2});
  }
  return total;
}

// torchvision AlexNet features: taps after the ReLUs at 1, 4, 7, 9, 11.
const std::vector<Layer> kAlexLayers = {{'C', 0, 4, 2, 0}, {'P', 2, 2, 0, 3}, {'C', 3, 1, 2, 0},
                                        {'P', 5, 2, 0, 3}, {'C', 6, 1, 1, 0}, {'C', 8, 1, 1, 0},
                                        {'C', 10, 1, 1, 0}};
const std::vector<int> kAlexTaps = {1, 4, 7, 9, 11};
// torchvision VGG16 features: taps after the ReLUs at 3, 8, 15, 22, 29.
const std::vector<Layer> kVggLayers = {
    {'C', 0, 1, 1, 0},  {'C', 2, 1, 1, 0},  {'P', 4, 2, 0, 2},  {'C', 5, 1, 1, 0},  {'C', 7, 1, 1, 0},
    {'P', 9, 2, 0, 2},  {'C', 10, 1, 1, 0}, {'C', 12, 1, 1, 0}, {'C', 14, 1, 1, 0}, {'P', 16, 2, 0, 2},
    {'C', 17, 1, 1, 0}, {'C', 19, 1, 1, 0}, {'C', 21, 1, 1, 0}, {'P', 23, 2, 0, 2}, {'C', 24, 1, 1, 0},
    {'C', 26, 1, 1, 0}, {'C', 28, 1, 1, 0}};
const std::vector<int> kVggTaps = {3, 8, 15, 22, 29};

}  // namespace

TEST_CASE("lpips alex matches the published values of the TID2013 pairs", "[lpips][oracle]") {
  const auto lpips = metrics_test::load_alex();
  const std::vector<std::pair<std::string, double>> published = {{"I03", 0.7237}, {"I04", 0.2572}};
  for (const auto& [name, expected] : published) {
    const auto ref = metrics_test::load_pair_image("ref", name);
    const auto dist = metrics_test::load_pair_image("dist", name);
    const double value = lpips.distance(dist, ref).item<double>();
    INFO(name << ": float " << value);
    CHECK_THAT(value, WithinAbs(expected, 1e-4));
    if (name == "I04") {  // float32 is accurate: double precision agrees to 1e-5 (one pair: slow)
      const double value_double =
          lpips.to(torch::kDouble).distance(dist.to(torch::kDouble), ref.to(torch::kDouble)).item<double>();
      INFO("double " << value_double);
      CHECK_THAT(value_double, WithinAbs(value, 1e-5));
    }
    // LPIPS is symmetric.
    CHECK_THAT(lpips.distance(ref, dist).item<double>(), WithinAbs(value, 1e-6));
  }
}

TEST_CASE("lpips alex equals the torchvision layer-list reference and batches independently", "[lpips]") {
  const auto dict = handscs::read_tensor_dict(metrics_test::lpips_alex_path());
  const auto lpips = metrics_test::load_alex().to(torch::kDouble);
  const auto x = metrics_test::smooth_image({2, 3, 67, 45}, 41);
  const auto y = metrics_test::smooth_image({2, 3, 67, 45}, 42);
  const auto value = lpips.distance(x, y);
  REQUIRE(value.sizes() == at::IntArrayRef({2}));
  const auto reference = lpips_reference(dict, kAlexLayers, kAlexTaps, x, y);
  CHECK((value - reference).abs().max().item<double>() < 1e-12);
  const auto single = lpips.distance(x.narrow(0, 1, 1), y.narrow(0, 1, 1));
  CHECK(single.item<double>() == Approx(value[1].item<double>()).epsilon(1e-12));
  CHECK(lpips.distance(x, x).abs().max().item<double>() == 0.0);
}

TEST_CASE("lpips vgg runs through the same code path as the torchvision VGG16 reference", "[lpips]") {
  // Random weights with the official VGG16 shapes, written and read back as a torch.save file.
  const auto& spec = handscs::lpips_net_spec("vgg");
  at::manual_seed(51);
  c10::Dict<std::string, at::Tensor> dict;
  handscs::TensorDict weights;
  for (const auto& [key, shape] : handscs::lpips_weight_shapes(spec)) {
    auto t = torch::randn(shape, torch::kFloat);
    if (shape.size() == 4 && shape[2] > 1) t *= std::sqrt(2.0 / (shape[1] * shape[2] * shape[3]));
    if (key.rfind("lin", 0) == 0) t = t.abs() * 0.1;
    if (shape.size() == 1) t *= 0.01;
    dict.insert(key, t);
    weights[key] = t;
  }
  const auto path = metrics_test::temp_dir("lpips_vgg") + "/lpips_vgg_random.pt";
  const auto bytes = torch::pickle_save(c10::IValue(dict));
  std::ofstream(path, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  handscs::LpipsConfig config;
  config.weights = path;
  config.net = "vgg";
  const auto lpips = handscs::Lpips(config).to(torch::kDouble);
  const auto x = metrics_test::smooth_image({1, 3, 40, 36}, 52);
  const auto y = metrics_test::smooth_image({1, 3, 40, 36}, 53);
  const double value = lpips.distance(x, y).item<double>();
  const double reference = lpips_reference(weights, kVggLayers, kVggTaps, x, y).item<double>();
  INFO("vgg lpips " << value << " reference " << reference);
  CHECK(value > 0);
  CHECK(value == Approx(reference).epsilon(1e-12));
  // An alex file given as vgg names the first key that does not fit.
  config.weights = metrics_test::lpips_alex_path();
  CHECK(metrics_test::error_of([&] { handscs::Lpips{config}; }) ==
        metrics_test::lpips_alex_path() +
            ": key 'net.slice1.0.weight': expected shape [64, 3, 3, 3], got [64, 3, 11, 11] (LPIPS net 'vgg')");
}

TEST_CASE("lpips input ranges: zero_one rescales, the others feed values as they are", "[lpips]") {
  handscs::LpipsConfig config;
  config.weights = metrics_test::lpips_alex_path();
  const auto x = metrics_test::smooth_image({1, 3, 48, 48}, 61, torch::kFloat);
  const auto y = metrics_test::smooth_image({1, 3, 48, 48}, 62, torch::kFloat);
  const double official = handscs::Lpips(config).distance(x, y).item<double>();
  config.input_range = "minus_one_one";
  const handscs::Lpips signed_input(config);
  CHECK(signed_input.distance(2 * x - 1, 2 * y - 1).item<double>() == Approx(official).epsilon(1e-5));
  const double as_signed = signed_input.distance(x, y).item<double>();
  config.input_range = "zero_one_unscaled";
  const double unscaled = handscs::Lpips(config).distance(x, y).item<double>();
  CHECK(unscaled == as_signed);
  CHECK(std::abs(unscaled - official) > 1e-3);  // the peers' shortcut changes the number
}

TEST_CASE("unit_normalize_channels keeps value and gradient finite for zero feature vectors", "[lpips][gradient]") {
  auto f = torch::zeros({1, 3, 1, 2}, torch::kDouble);
  f[0][0][0][1] = 3.0;
  f[0][1][0][1] = 4.0;  // position 1 has norm 5, position 0 is all zero
  f.set_requires_grad(true);
  const auto n = handscs::unit_normalize_channels(f);
  CHECK(n[0][0][0][1].item<double>() == Approx(3.0 / (5.0 + 1e-10)).epsilon(1e-15));
  CHECK(n[0][0][0][0].item<double>() == 0.0);
  const auto v = torch::tensor({1.0, 2.0, -1.0, 0.5, 0.25, 2.0}, torch::kDouble).view({1, 3, 1, 2});
  const auto grad = torch::autograd::grad({(n * v).sum()}, {f})[0];
  CHECK(grad.isfinite().all().item<bool>());
  // At the zero vector n(f) = f / 1e-10 to first order, so the gradient is v / 1e-10.
  CHECK(grad[0][0][0][0].item<double>() == Approx(1.0 / 1e-10).epsilon(1e-12));
  CHECK(grad[0][1][0][0].item<double>() == Approx(-1.0 / 1e-10).epsilon(1e-12));
  // At a non-zero vector it is the usual (v - n (n . v)) / (|f| + eps) with |f| = 5 (up to eps).
  const auto gv = grad.select(3, 1).view({3});
  const auto nv = torch::tensor({0.6, 0.8, 0.0}, torch::kDouble);
  const auto vv = torch::tensor({2.0, 0.5, 2.0}, torch::kDouble);
  const auto expected = (vv - nv * (nv * vv).sum()) / 5.0;
  CHECK((gv - expected).abs().max().item<double>() < 1e-9);
}

TEST_CASE("lpips loss gradients match finite differences (double, alex)", "[lpips][gradient]") {
  const auto lpips = metrics_test::load_alex().to(torch::kDouble);
  const auto x = metrics_test::smooth_image({1, 3, 40, 44}, 71);
  const auto y = metrics_test::smooth_image({1, 3, 40, 44}, 72);
  // Central differences, step 1e-6, on 40 random pixels and 4 random directions, for each input.
  const auto check_x = metrics_test::check_gradient(
      [&](const torch::Tensor& t) { return handscs::lpips_loss(lpips, t, y); }, x, 1e-6, 40, 4);
  INFO("d/dpred: max |error| " << check_x.max_abs_error << ", max |grad| " << check_x.max_abs_grad);
  CHECK(check_x.max_abs_grad > 1e-4);
  CHECK(check_x.relative() < 1e-5);
  const auto check_y = metrics_test::check_gradient(
      [&](const torch::Tensor& t) { return handscs::lpips_loss(lpips, x, t); }, y, 1e-6, 40, 4, 9);
  INFO("d/dtarget: max |error| " << check_y.max_abs_error << ", max |grad| " << check_y.max_abs_grad);
  CHECK(check_y.relative() < 1e-5);
  // Both sides needing gradients takes the batched path; it must give the same gradients.
  auto xa = x.clone().set_requires_grad(true), ya = y.clone().set_requires_grad(true);
  const auto both = torch::autograd::grad({handscs::lpips_loss(lpips, xa, ya)}, {xa, ya});
  auto xb = x.clone().set_requires_grad(true);
  const auto only_x = torch::autograd::grad({handscs::lpips_loss(lpips, xb, y)}, {xb})[0];
  CHECK((both[0] - only_x).abs().max().item<double>() < 1e-12);
  auto yb = y.clone().set_requires_grad(true);
  const auto only_y = torch::autograd::grad({handscs::lpips_loss(lpips, x, yb)}, {yb})[0];
  CHECK((both[1] - only_y).abs().max().item<double>() < 1e-12);
}

TEST_CASE("lpips rejects wrong shapes, dtypes and too-small images", "[lpips]") {
  const auto lpips = metrics_test::load_alex();
  CHECK_THROWS_WITH(lpips.distance(torch::zeros({1, 1, 64, 64}), torch::zeros({1, 1, 64, 64})),
                    Catch::Contains("lpips: images must be [B, 3, H, W], got [2, 1, 64, 64]"));
  CHECK_THROWS_WITH(lpips.distance(torch::zeros({1, 3, 64, 64}), torch::zeros({1, 3, 64, 65})),
                    Catch::Contains("lpips: image sizes differ: [1, 3, 64, 64] vs [1, 3, 64, 65]"));
  CHECK_THROWS_WITH(lpips.distance(torch::zeros({1, 3, 64, 64}, torch::kDouble),
                                   torch::zeros({1, 3, 64, 64}, torch::kDouble)),
                    Catch::Contains("lpips: images are Double but the weights are Float (use Lpips::to)"));
  CHECK_THROWS_WITH(lpips.distance(torch::zeros({1, 3, 12, 64}), torch::zeros({1, 3, 12, 64})),
                    Catch::Contains("lpips: images 12x64 are too small for LPIPS net 'alex' (stage 2 gets 2x15)"));
}

TEST_CASE("lpips min_image_side is the smallest side features() accepts (brute force)", "[lpips]") {
  const auto lpips = metrics_test::load_alex();
  const int64_t side = lpips.min_image_side();
  const auto accepts = [&](int64_t s) {
    try {
      lpips.features(torch::zeros({1, 3, s, s}));
      return true;
    } catch (const c10::Error&) {
      return false;
    }
  };
  for (int64_t s = 1; s < side; ++s) {
    INFO("side " << s);
    CHECK_FALSE(accepts(s));
  }
  for (int64_t s = side; s < side + 8; ++s) {
    INFO("side " << s);
    CHECK(accepts(s));
  }
}
