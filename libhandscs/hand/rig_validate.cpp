// Consistency checks of a rig: see rig_validate.h.
#include "hand/rig_validate.h"

#include <ATen/ATen.h>

#include <cmath>

#include "core/error.h"
#include "core/text.h"
#include "hand/joint_order.h"

namespace handscs {

namespace {

std::string index_text(const std::vector<int64_t>& index) {
  std::string text;
  for (int64_t i : index) text += "[" + std::to_string(i) + "]";
  return text;
}

// Multi-index of flat position `flat` in a tensor of `sizes`.
std::vector<int64_t> unflatten(int64_t flat, at::IntArrayRef sizes) {
  std::vector<int64_t> index(sizes.size());
  for (int64_t d = static_cast<int64_t>(sizes.size()) - 1; d >= 0; --d) {
    index[d] = flat % sizes[d];
    flat /= sizes[d];
  }
  return index;
}

struct Checker {
  const std::string& source;

  [[noreturn]] void fail(const std::string& key, const std::string& problem) const {
    throw Error(source + ": " + key + ": " + problem);
  }

  void shape(const torch::Tensor& tensor, const std::string& key,
             std::vector<int64_t> expected) const {
    if (!tensor.defined()) fail(key, "missing");
    if (tensor.sizes() != at::IntArrayRef(expected))
      fail(key, "expected shape " + shape_text(expected) + ", got " + shape_text(tensor.sizes()));
  }

  void finite(const torch::Tensor& tensor, const std::string& key) const {
    const torch::Tensor bad = torch::logical_not(torch::isfinite(tensor)).reshape(-1).nonzero();
    if (bad.numel() > 0)
      fail(key + index_text(unflatten(bad[0].item<int64_t>(), tensor.sizes())), "non-finite value");
  }
};

}  // namespace

void validate_rig(const Rig& rig, const std::string& source) {
  const Checker check{source};
  if (!rig.v_template.defined() || rig.v_template.dim() != 2 || rig.v_template.size(1) != 3)
    check.fail("v_template", rig.v_template.defined() ? "expected shape [V, 3], got " +
                                                            shape_text(rig.v_template.sizes())
                                                      : "missing");
  const int64_t num_vertices = rig.v_template.size(0);
  if (num_vertices < 1) check.fail("v_template", "no vertices");
  check.finite(rig.v_template, "v_template");

  if (!rig.faces.defined() || rig.faces.dim() != 2 || rig.faces.size(1) != 3)
    check.fail("faces", rig.faces.defined()
                            ? "expected shape [F, 3], got " + shape_text(rig.faces.sizes())
                            : "missing");
  {
    const torch::Tensor faces = rig.faces.to(torch::kInt64).contiguous();
    const int64_t* f = faces.data_ptr<int64_t>();
    for (int64_t i = 0; i < faces.numel(); ++i)
      if (f[i] < 0 || f[i] >= num_vertices)
        check.fail("faces[" + std::to_string(i / 3) + "][" + std::to_string(i % 3) + "]",
                   "vertex index " + std::to_string(f[i]) + " out of range [0, " +
                       std::to_string(num_vertices) + ")");
  }

  check.shape(rig.weights, "weights", {num_vertices, kRigJoints});
  check.finite(rig.weights, "weights");
  {
    const torch::Tensor weights = rig.weights.to(torch::kFloat64).contiguous();
    const double* w = weights.data_ptr<double>();
    for (int64_t v = 0; v < num_vertices; ++v) {
      double sum = 0;
      for (int k = 0; k < kRigJoints; ++k) {
        const double value = w[v * kRigJoints + k];
        if (value < -kRigSumTolerance)
          check.fail("weights[" + std::to_string(v) + "][" + std::to_string(k) + "]",
                     "negative weight " + std::to_string(value));
        sum += value;
      }
      if (std::abs(sum - 1.0) > kRigSumTolerance)
        check.fail("weights[" + std::to_string(v) + "]",
                   "row sums to " + std::to_string(sum) + ", expected 1");
    }
  }

  check.shape(rig.j_regressor, "j_regressor", {kRigJoints, num_vertices});
  check.finite(rig.j_regressor, "j_regressor");
  if (rig.parents.size() != kManoParents.size() ||
      !std::equal(rig.parents.begin(), rig.parents.end(), kManoParents.begin())) {
    std::string expected, got;
    for (size_t i = 0; i < kManoParents.size(); ++i)
      expected += (i ? ", " : "") + std::to_string(kManoParents[i]);
    for (size_t i = 0; i < rig.parents.size(); ++i)
      got += (i ? ", " : "") + std::to_string(rig.parents[i]);
    check.fail("parents", "expected the MANO parents [" + expected + "], got [" + got + "]");
  }

  check.shape(rig.posedirs, "posedirs", {num_vertices, 3, kPoseFeatureDim});
  check.finite(rig.posedirs, "posedirs");
  check.shape(rig.shapedirs, "shapedirs", {num_vertices, 3, kShapeDim});
  check.finite(rig.shapedirs, "shapedirs");
  check.shape(rig.hands_mean, "hands_mean", {kPoseDim - 3});
  check.finite(rig.hands_mean, "hands_mean");

  for (size_t i = 0; i < rig.tip_vertices.size(); ++i)
    if (rig.tip_vertices[i] < 0 || rig.tip_vertices[i] >= num_vertices)
      check.fail("tip_vertices[" + std::to_string(i) + "]",
                 "vertex index " + std::to_string(rig.tip_vertices[i]) + " out of range [0, " +
                     std::to_string(num_vertices) + ")");

  if (rig.vertex_labels.defined()) {
    check.shape(rig.vertex_labels, "vertex_labels", {num_vertices});
    const int64_t lowest = rig.vertex_labels.min().item<int64_t>();
    if (lowest < 0) check.fail("vertex_labels", "negative label " + std::to_string(lowest));
  }
}

}  // namespace handscs
