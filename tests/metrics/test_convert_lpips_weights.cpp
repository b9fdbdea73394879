// scripts/convert_lpips_weights.py end to end on fake sources with the official key names (built
// here from the shared LPIPS file), when a python3 with torch is available. The official sources
// (torchvision's alexnet-owt-7be5be79.pth, LPIPS's alex.pth) are not available offline.
#include "metrics_test_utils.h"  // first: brings Catch2 in after torch (see there)

#include <sys/wait.h>

#include <cstdlib>
#include <fstream>

#include <torch/csrc/api/include/torch/serialize.h>

#include "core/atomic_file.h"
#include "metrics/lpips.h"

namespace {

// First of python3, /usr/bin/python3 that can import torch ("" if none).
std::string python_with_torch() {
  for (const char* candidate : {"python3", "/usr/bin/python3"}) {
    const std::string command = std::string(candidate) + " -c 'import torch' > /dev/null 2>&1";
    if (std::system(command.c_str()) == 0) return candidate;
  }
  return "";
}

void save_dict(const std::string& path, const c10::Dict<std::string, at::Tensor>& dict) {
  const auto bytes = torch::pickle_save(c10::IValue(dict));
  std::ofstream(path, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

int run(const std::string& command, const std::string& log) {
  const int raw = std::system((command + " > " + log + " 2>&1").c_str());
  return WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
}

}  // namespace

TEST_CASE("convert_lpips_weights.py rebuilds the LPIPS file from torchvision-style sources", "[lpips][script]") {
  const std::string python = python_with_torch();
  if (python.empty()) {
    WARN("skipped: no python3 with torch (Debian: python3-torch); the converter is untested here");
    return;
  }
  const auto dir = metrics_test::temp_dir("convert_lpips");
  const auto shared = handscs::read_tensor_dict(metrics_test::lpips_alex_path());
  // Fake torchvision AlexNet state dict: features.N from the shared file, plus a classifier key.
  c10::Dict<std::string, at::Tensor> backbone, lins;
  for (const auto& [key, tensor] : shared) {
    if (key.rfind("net.slice", 0) == 0) {
      const auto layer = key.substr(key.find('.', 4) + 1);  // "0.weight" from "net.slice1.0.weight"
      backbone.insert("features." + layer, tensor);
    } else {
      lins.insert(key, tensor);
    }
  }
  backbone.insert("classifier.1.bias", torch::zeros({16}));
  save_dict(dir + "/alexnet-owt.pth", backbone);
  save_dict(dir + "/alex.pth", lins);

  const std::string script = std::string(HANDSCS_SOURCE_DIR) + "/scripts/convert_lpips_weights.py";
  const std::string out = dir + "/lpips_alex_v0.1.pt";
  const int status = run(python + " " + script + " --net alex --backbone " + dir + "/alexnet-owt.pth --lin " +
                             dir + "/alex.pth --out " + out,
                         dir + "/log.txt");
  INFO(handscs::read_file(dir + "/log.txt"));
  REQUIRE(status == 0);
  const auto converted = handscs::read_tensor_dict(out);
  REQUIRE(converted.size() == shared.size());
  for (const auto& [key, tensor] : shared) {
    INFO(key);
    REQUIRE(converted.count(key) == 1);
    CHECK(torch::equal(converted.at(key), tensor));
  }
  handscs::LpipsConfig config;
  config.weights = out;
  const auto ref = metrics_test::load_pair_image("ref", "I04");
  const auto dist = metrics_test::load_pair_image("dist", "I04");
  CHECK(handscs::Lpips(config).distance(dist, ref).item<double>() == Approx(0.2572).margin(1e-4));

  // VGG: fake torchvision VGG16 / vgg.pth sources built from the C++ spec's shapes; the output
  // must pass the loader's key and shape checks for net 'vgg'.
  c10::Dict<std::string, at::Tensor> vgg_backbone, vgg_lins;
  for (const auto& [key, shape] : handscs::lpips_weight_shapes(handscs::lpips_net_spec("vgg"))) {
    if (key.rfind("net.slice", 0) == 0)
      vgg_backbone.insert("features." + key.substr(key.find('.', 4) + 1), torch::full(shape, 0.01f));
    else
      vgg_lins.insert(key, torch::full(shape, 0.5f));
  }
  save_dict(dir + "/vgg16.pth", vgg_backbone);
  save_dict(dir + "/vgg.pth", vgg_lins);
  REQUIRE(run(python + " " + script + " --net vgg --backbone " + dir + "/vgg16.pth --lin " + dir +
                  "/vgg.pth --out " + dir + "/lpips_vgg.pt",
              dir + "/log_vgg.txt") == 0);
  const auto vgg = handscs::select_lpips_weights(handscs::read_tensor_dict(dir + "/lpips_vgg.pt"),
                                                 handscs::lpips_net_spec("vgg"), "lpips_vgg.pt");
  CHECK(vgg.size() == 31);
  CHECK(vgg.at("net.slice4.21.bias").sizes() == at::IntArrayRef({512}));

  // A source without a needed key fails with the file and key.
  (void)backbone.erase("features.8.weight");
  save_dict(dir + "/broken.pth", backbone);
  const int broken = run(python + " " + script + " --backbone " + dir + "/broken.pth --lin " + dir +
                             "/alex.pth --out " + dir + "/x.pt",
                         dir + "/log2.txt");
  CHECK(broken == 1);
  CHECK(handscs::read_file(dir + "/log2.txt").find("error: " + dir + "/broken.pth: missing key 'features.8.weight'") !=
        std::string::npos);
}
