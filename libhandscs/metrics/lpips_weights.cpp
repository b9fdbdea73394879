#include "metrics/lpips_weights.h"


#include <ATen/ATen.h>
#include <torch/csrc/jit/serialization/pickle.h>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/text.h"

namespace handscs {

namespace {

std::string first_line(const std::string& text) {
  const auto end = text.find('\n');
  return end == std::string::npos ? text : text.substr(0, end);
}

}  // namespace

TensorDict read_tensor_dict(const std::string& path) {
  // LPIPS weight files are 10 MB (AlexNet) to 60 MB (VGG); 1 GB is no LPIPS file.
  const std::string bytes = read_file(path, std::uintmax_t{1} << 30);
  c10::IValue value;
  try {
    value = torch::jit::pickle_load(std::vector<char>(bytes.begin(), bytes.end()));
  } catch (const c10::Error& e) {
    throw Error(path + ": not a readable torch.save file (" + first_line(e.what_without_backtrace()) +
                ")");
  } catch (const std::exception& e) {
    throw Error(path + ": not a readable torch.save file (" + first_line(e.what()) + ")");
  }
  if (!value.isGenericDict())
    throw Error(path + ": expected a dict of tensors (torch.save of a dict), got " +
                value.tagKind());
  TensorDict dict;
  for (const auto& item : value.toGenericDict()) {
    if (!item.key().isString())
      throw Error(path + ": expected string keys, got a " + item.key().tagKind() + " key");
    const std::string key = item.key().toStringRef();
    if (!item.value().isTensor())
      throw Error(path + ": key '" + key + "': expected a tensor, got " + item.value().tagKind());
    dict[key] = item.value().toTensor();
  }
  return dict;
}

std::vector<std::pair<std::string, std::vector<int64_t>>> lpips_weight_shapes(
    const LpipsNetSpec& spec) {
  std::vector<std::pair<std::string, std::vector<int64_t>>> shapes;
  for (const auto& stage : spec.stages) {
    for (const auto& conv : stage.convs) {
      shapes.push_back({conv.key + ".weight",
                        {conv.out_channels, conv.in_channels, conv.kernel, conv.kernel}});
      shapes.push_back({conv.key + ".bias", {conv.out_channels}});
    }
  }
  for (size_t t = 0; t < spec.stages.size(); ++t)
    shapes.push_back({"lin" + std::to_string(t) + ".model.1.weight",
                      {1, spec.stages[t].channels(), 1, 1}});
  return shapes;
}

TensorDict select_lpips_weights(const TensorDict& dict, const LpipsNetSpec& spec,
                                const std::string& source) {
  TensorDict selected;
  for (const auto& [key, shape] : lpips_weight_shapes(spec)) {
    const auto it = dict.find(key);
    if (it == dict.end())
      throw Error(source + ": missing key '" + key + "' (LPIPS net '" + spec.name + "' needs " +
                  std::to_string(lpips_weight_shapes(spec).size()) + " keys; see docs/METRICS.md)");
    const auto& tensor = it->second;
    if (tensor.sizes() != at::IntArrayRef(shape))
      throw Error(source + ": key '" + key + "': expected shape " + shape_text(shape) + ", got " +
                  shape_text(tensor.sizes()) + " (LPIPS net '" + spec.name + "')");
    if (!at::isFloatingType(tensor.scalar_type()))
      throw Error(source + ": key '" + key + "': expected floating-point values, got " +
                  std::string(c10::toString(tensor.scalar_type())));
    const auto values = tensor.to(at::kFloat).contiguous();
    if (!values.isfinite().all().item<bool>())
      throw Error(source + ": key '" + key + "': holds NaN or infinite values");
    selected[key] = values;
  }
  return selected;
}

}  // namespace handscs
