// LPIPS weight files: a Python torch.save dict[str, Tensor] with the official LPIPS key names
// (net.sliceS.I.{weight,bias} for the backbone, linT.model.1.weight for the 1x1 lin layers).
#pragma once

#include <map>
#include <string>
#include <vector>

#include <torch/types.h>

#include "metrics/lpips_nets.h"

namespace handscs {

using TensorDict = std::map<std::string, torch::Tensor>;

// Reads a torch.save dict of tensors (via torch::pickle_load). Throws Error naming `path` when the
// file is missing, is not a torch.save file, or holds something other than dict[str, Tensor].
TensorDict read_tensor_dict(const std::string& path);

// Every key `spec` needs, with its shape: conv weights/biases, then lin0..lin4 [1, C, 1, 1].
std::vector<std::pair<std::string, std::vector<int64_t>>> lpips_weight_shapes(const LpipsNetSpec& spec);

// The tensors `spec` needs from `dict`, as contiguous float32, after checking presence, shape and
// finiteness. Errors read "<source>: key 'net.slice1.0.weight': ..." (`source` is the file name).
TensorDict select_lpips_weights(const TensorDict& dict, const LpipsNetSpec& spec,
                                const std::string& source);

}  // namespace handscs
