// LPIPS weight files: the shared file's keys, and the error for each kind of bad file (naming the
// file and the key).
#include "metrics_test_utils.h"  // first: brings Catch2 in after torch (see there)

#include <fstream>

#include <torch/csrc/api/include/torch/serialize.h>

#include "metrics/lpips.h"

namespace {

std::string write_bytes(const std::string& path, const std::vector<char>& bytes) {
  std::ofstream(path, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  return path;
}

// The shared alex dict with `edit` applied, written to `name` in a temp folder.
std::string edited_alex_file(const std::string& name,
                             const std::function<void(c10::Dict<std::string, at::Tensor>&)>& edit) {
  c10::Dict<std::string, at::Tensor> dict;
  for (const auto& [key, tensor] : handscs::read_tensor_dict(metrics_test::lpips_alex_path()))
    dict.insert(key, tensor);
  edit(dict);
  return write_bytes(metrics_test::temp_dir("lpips_weights_" + name) + "/" + name + ".pt",
                     torch::pickle_save(c10::IValue(dict)));
}

std::string load_error(const std::string& path, const std::string& net = "alex") {
  handscs::LpipsConfig config;
  config.weights = path;
  config.net = net;
  return metrics_test::error_of([&] { handscs::Lpips{config}; });
}

}  // namespace

TEST_CASE("the shared LPIPS alex file holds the 15 official keys with the expected shapes", "[lpips][weights]") {
  const auto dict = handscs::read_tensor_dict(metrics_test::lpips_alex_path());
  CHECK(dict.size() == 15);
  const auto& spec = handscs::lpips_net_spec("alex");
  const auto shapes = handscs::lpips_weight_shapes(spec);
  REQUIRE(shapes.size() == 15);
  CHECK(shapes.front().first == "net.slice1.0.weight");
  CHECK(shapes.back().first == "lin4.model.1.weight");
  const auto selected = handscs::select_lpips_weights(dict, spec, "x");
  CHECK(selected.at("net.slice2.3.weight").sizes() == at::IntArrayRef({192, 64, 5, 5}));
  // The lin weights of LPIPS v0.1 are non-negative.
  for (int t = 0; t < 5; ++t)
    CHECK(selected.at("lin" + std::to_string(t) + ".model.1.weight").min().item<float>() >= 0);
}

TEST_CASE("lpips weight errors name the file and the key", "[lpips][weights]") {
  SECTION("missing file") {
    CHECK(load_error("/nonexistent/lpips.pt") == "/nonexistent/lpips.pt: cannot open file");
  }
  SECTION("no file given") {
    CHECK(load_error("") == "LPIPS: no weight file given (lpips.weights)");
  }
  SECTION("not a torch.save file") {
    const auto path = metrics_test::temp_dir("lpips_weights_text") + "/text.pt";
    std::ofstream(path) << "not a pickle";
    CHECK_THAT(load_error(path), Catch::StartsWith(path + ": not a readable torch.save file ("));
  }
  SECTION("a tensor instead of a dict") {
    const auto path = write_bytes(metrics_test::temp_dir("lpips_weights_tensor") + "/tensor.pt",
                                  torch::pickle_save(c10::IValue(torch::zeros({3}))));
    CHECK(load_error(path) == path + ": expected a dict of tensors (torch.save of a dict), got Tensor");
  }
  SECTION("missing key") {
    const auto path = edited_alex_file("missing", [](auto& d) { (void)d.erase("lin4.model.1.weight"); });
    CHECK(load_error(path) ==
          path + ": missing key 'lin4.model.1.weight' (LPIPS net 'alex' needs 15 keys; see docs/METRICS.md)");
  }
  SECTION("wrong shape") {
    const auto path = edited_alex_file("shape", [](auto& d) {
      d.insert_or_assign("net.slice1.0.weight", torch::zeros({64, 3, 3, 3}));
    });
    CHECK(load_error(path) == path + ": key 'net.slice1.0.weight': expected shape [64, 3, 11, 11], got "
                                     "[64, 3, 3, 3] (LPIPS net 'alex')");
  }
  SECTION("non-finite values") {
    const auto path = edited_alex_file("nan", [](auto& d) {
      auto lin = d.at("lin2.model.1.weight").clone();
      lin[0][7][0][0] = std::numeric_limits<float>::quiet_NaN();
      d.insert_or_assign("lin2.model.1.weight", lin);
    });
    CHECK(load_error(path) == path + ": key 'lin2.model.1.weight': holds NaN or infinite values");
  }
  SECTION("unknown net") {
    CHECK(metrics_test::error_of([] { handscs::lpips_net_spec("resnet"); }) ==
          "unknown LPIPS net \"resnet\" (known: alex, vgg)");
  }
}
