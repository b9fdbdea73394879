// The LPIPS backbones by name ("alex", "vgg"): the layers before each of the five feature taps, with
// the official LPIPS weight-key names (net.sliceS.I.{weight,bias}) and the lin-layer widths.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace handscs {

// One convolution followed by a ReLU; `key` is the weight-key prefix in the LPIPS file.
struct LpipsConv {
  std::string key;          // e.g. "net.slice2.3" (weight "<key>.weight", bias "<key>.bias")
  int64_t in_channels = 0;
  int64_t out_channels = 0;
  int64_t kernel = 0;       // square kernel size
  int64_t stride = 1;
  int64_t padding = 0;
};

// Layers from the previous tap to this tap: an optional max-pool, then conv+ReLU layers.
struct LpipsStage {
  int64_t pool_kernel = 0;  // 0 = no pooling
  int64_t pool_stride = 0;
  std::vector<LpipsConv> convs;
  int64_t channels() const { return convs.back().out_channels; }  // width of the tap
};

struct LpipsNetSpec {
  std::string name;
  std::vector<LpipsStage> stages;  // five taps in LPIPS v0.1
};

// Registry: the spec of `name`; throws Error for an unknown name, listing the known ones.
const LpipsNetSpec& lpips_net_spec(const std::string& name);

// Known names, in registry order ("alex", "vgg").
std::vector<std::string> lpips_net_names();

}  // namespace handscs
