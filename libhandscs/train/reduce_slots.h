// The values one data-parallel step sums across ranks, by name: each part of training adds its
// slots, one all-reduce sums them all, and each part reads its own back by the same name.
//
//   ReduceSlots slots;
//   slots.add("densify/visible", visible);       // any shape, float32 on the wire
//   slots.add_scalar("loss", loss);
//   slots.all_reduce(group);                      // one collective for everything
//   visible = slots.get("densify/visible");       // the sum over ranks, shaped as added
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <torch/types.h>

#include "train/data_parallel.h"

namespace handscs {

class ReduceSlots {
 public:
  // Adds a slot (a name may be added once). Every rank must add the same names with the same
  // sizes, in any order.
  void add(const std::string& name, const torch::Tensor& values);
  void add_scalar(const std::string& name, double value);

  // Sums every slot over the ranks in one all-reduce (slots are laid out sorted by name, so the
  // order of add() calls does not matter).
  void all_reduce(ProcessGroup& group);

  torch::Tensor get(const std::string& name) const;  // shaped as added (a view of the sum)
  double scalar(const std::string& name) const;
  bool all_finite() const;  // after all_reduce: every summed value is finite

  // Names added and read from now on are "<scope><name>" (data.hand both: "left/" while the second
  // hand's parts add and read theirs, so that the two hands' slots stay apart).
  void set_scope(const std::string& scope) { scope_ = scope; }

 private:
  std::string scope_;
  std::vector<std::pair<std::string, torch::Tensor>> slots_;
  std::map<std::string, size_t> index_;
};

}  // namespace handscs
