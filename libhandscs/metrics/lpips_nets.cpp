#include "metrics/lpips_nets.h"

#include "core/error.h"

namespace handscs {

namespace {

// torchvision AlexNet `features`, split at the ReLUs LPIPS taps (indices 1, 4, 7, 9, 11).
LpipsNetSpec make_alex() {
  LpipsNetSpec spec{"alex", {}};
  spec.stages.push_back({0, 0, {{"net.slice1.0", 3, 64, 11, 4, 2}}});
  spec.stages.push_back({3, 2, {{"net.slice2.3", 64, 192, 5, 1, 2}}});
  spec.stages.push_back({3, 2, {{"net.slice3.6", 192, 384, 3, 1, 1}}});
  spec.stages.push_back({0, 0, {{"net.slice4.8", 384, 256, 3, 1, 1}}});
  spec.stages.push_back({0, 0, {{"net.slice5.10", 256, 256, 3, 1, 1}}});
  return spec;
}

// torchvision VGG16 `features`, tapped at relu1_2, relu2_2, relu3_3, relu4_3, relu5_3.
LpipsNetSpec make_vgg() {
  LpipsNetSpec spec{"vgg", {}};
  auto conv = [](const std::string& key, int64_t in, int64_t out) {
    return LpipsConv{key, in, out, 3, 1, 1};
  };
  spec.stages.push_back({0, 0, {conv("net.slice1.0", 3, 64), conv("net.slice1.2", 64, 64)}});
  spec.stages.push_back({2, 2, {conv("net.slice2.5", 64, 128), conv("net.slice2.7", 128, 128)}});
  spec.stages.push_back({2, 2,
                         {conv("net.slice3.10", 128, 256), conv("net.slice3.12", 256, 256),
                          conv("net.slice3.14", 256, 256)}});
  spec.stages.push_back({2, 2,
                         {conv("net.slice4.17", 256, 512), conv("net.slice4.19", 512, 512),
                          conv("net.slice4.21", 512, 512)}});
  spec.stages.push_back({2, 2,
                         {conv("net.slice5.24", 512, 512), conv("net.slice5.26", 512, 512),
                          conv("net.slice5.28", 512, 512)}});
  return spec;
}

const std::vector<LpipsNetSpec>& registry() {
  static const std::vector<LpipsNetSpec> specs = {make_alex(), make_vgg()};
  return specs;
}

}  // namespace

const LpipsNetSpec& lpips_net_spec(const std::string& name) {
  for (const auto& spec : registry())
    if (spec.name == name) return spec;
  std::string known;
  for (const auto& known_name : lpips_net_names()) known += (known.empty() ? "" : ", ") + known_name;
  throw Error("unknown LPIPS net \"" + name + "\" (known: " + known + ")");
}

std::vector<std::string> lpips_net_names() {
  std::vector<std::string> names;
  for (const auto& spec : registry()) names.push_back(spec.name);
  return names;
}

}  // namespace handscs
