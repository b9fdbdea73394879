// Rig files (docs/RIG_FORMAT.md): JSON, metres, one key per line; arrays dense (nested lists) or
// sparse ({"shape": [...], "sparse": [[i, j, ..., value], ...]}). Numbers are written with full
// round-trip precision, so save -> load reproduces every float64 exactly.
#include <ATen/ATen.h>

#include <cmath>
#include <functional>
#include <nlohmann/json.hpp>
#include <set>
#include <spdlog/spdlog.h>
#include <sstream>

#include "core/atomic_file.h"
#include "core/config.h"
#include "core/error.h"
#include "core/text.h"
#include "hand/finger_length_modes.h"
#include "hand/joint_order.h"
#include "hand/procedural_hand.h"
#include "hand/rig.h"
#include "hand/rig_handedness.h"
#include "hand/rig_validate.h"

namespace handscs {

namespace {

using json = nlohmann::json;

constexpr const char* kFormatName = "handscs-rig";
constexpr int kFormatVersion = 1;

class RigReader {
 public:
  RigReader(const json& root, std::string path) : root_(root), path_(std::move(path)) {}

  [[noreturn]] void fail(const std::string& key, const std::string& problem) const {
    throw Error(path_ + ": " + key + ": " + problem);
  }

  const json& get(const std::string& key) const {
    const auto it = root_.find(key);
    if (it == root_.end()) throw Error(path_ + ": missing key '" + key + "'");
    return *it;
  }

  std::string string(const std::string& key) const {
    const json& value = get(key);
    if (!value.is_string()) fail(key, "expected string, got " + json_type_name(value));
    return value.get<std::string>();
  }

  // A float64 tensor of the expected shape from a dense nested list or a sparse object.
  torch::Tensor floats(const std::string& key, const std::vector<int64_t>& shape) const {
    const json& value = get(key);
    std::vector<double> data(static_cast<size_t>(numel(shape)), 0.0);
    if (value.is_object()) {
      read_sparse(value, key, shape, data);
    } else {
      check_dense_shape(value, key, shape);
      size_t cursor = 0;
      std::vector<int64_t> index;
      read_dense(value, key, shape, index, data, cursor, /*integers=*/false);
    }
    return torch::tensor(data, torch::kFloat64).reshape(shape);
  }

  // int64 values of a dense nested list; a leading -1 in `shape` takes the list's length.
  std::vector<int64_t> integers(const std::string& key, std::vector<int64_t>& shape) const {
    const json& value = get(key);
    if (!shape.empty() && shape[0] < 0) {
      if (!value.is_array()) fail(key, "expected array, got " + json_type_name(value));
      shape[0] = static_cast<int64_t>(value.size());
    }
    check_dense_shape(value, key, shape);
    std::vector<double> data(static_cast<size_t>(numel(shape)), 0.0);
    size_t cursor = 0;
    std::vector<int64_t> index;
    read_dense(value, key, shape, index, data, cursor, /*integers=*/true);
    return std::vector<int64_t>(data.begin(), data.end());
  }

 private:
  static int64_t numel(const std::vector<int64_t>& shape) {
    int64_t n = 1;
    for (int64_t s : shape) n *= s;
    return n;
  }

  // Compares the shape seen along first elements with the expected one.
  void check_dense_shape(const json& value, const std::string& key,
                         const std::vector<int64_t>& shape) const {
    if (!value.is_array()) fail(key, "expected array, got " + json_type_name(value));
    std::vector<int64_t> seen;
    const json* cursor = &value;
    while (cursor->is_array() && seen.size() < shape.size() + 1) {
      seen.push_back(static_cast<int64_t>(cursor->size()));
      if (cursor->empty()) break;
      cursor = &(*cursor)[0];
    }
    const bool complete = seen.size() == shape.size() && !cursor->is_array();
    const bool empty_ok = seen.size() < shape.size() && !seen.empty() && seen.back() == 0 &&
                          std::equal(seen.begin(), seen.end(), shape.begin());
    if (!(complete && seen == shape) && !empty_ok)
      fail(key, "expected shape " + shape_text(shape) + ", got " + shape_text(seen));
  }

  // Flattens a nested list; `index` is the position reached, turned into "key[i][j]" only on error.
  void read_dense(const json& value, const std::string& key, const std::vector<int64_t>& shape,
                  std::vector<int64_t>& index, std::vector<double>& out, size_t& cursor,
                  bool integers) const {
    auto where = [&] {
      std::string text = key;
      for (int64_t i : index) text += "[" + std::to_string(i) + "]";
      return text;
    };
    const size_t depth = index.size();
    if (depth == shape.size()) {
      if (!value.is_number()) fail(where(), "expected number, got " + json_type_name(value));
      if (integers && !value.is_number_integer())
        fail(where(), "expected integer, got " + value.dump());
      out[cursor++] = integers ? static_cast<double>(value.get<int64_t>()) : value.get<double>();
      return;
    }
    if (!value.is_array()) fail(where(), "expected array, got " + json_type_name(value));
    if (static_cast<int64_t>(value.size()) != shape[depth])
      fail(where(), "expected " + std::to_string(shape[depth]) + " entries, got " +
                        std::to_string(value.size()));
    index.push_back(0);
    for (size_t i = 0; i < value.size(); ++i) {
      index.back() = static_cast<int64_t>(i);
      read_dense(value[i], key, shape, index, out, cursor, integers);
    }
    index.pop_back();
  }

  void read_sparse(const json& value, const std::string& key, const std::vector<int64_t>& shape,
                   std::vector<double>& out) const {
    for (const auto& item : value.items())
      if (item.key() != "shape" && item.key() != "sparse")
        fail(key, "unknown key '" + item.key() + "' in sparse array (expected shape, sparse)");
    if (!value.contains("shape") || !value.contains("sparse"))
      fail(key, "a sparse array needs 'shape' and 'sparse'");
    std::vector<int64_t> file_shape;
    const json& shape_value = value["shape"];
    if (!shape_value.is_array())
      fail(key + ".shape", "expected array, got " + json_type_name(shape_value));
    for (const json& s : shape_value) {
      if (!s.is_number_integer()) fail(key + ".shape", "expected integers");
      file_shape.push_back(s.get<int64_t>());
    }
    if (file_shape != shape)
      fail(key, "expected shape " + shape_text(shape) + ", got " + shape_text(file_shape));
    const json& entries = value["sparse"];
    if (!entries.is_array()) fail(key + ".sparse", "expected array, got " + json_type_name(entries));
    for (size_t e = 0; e < entries.size(); ++e) {
      const std::string where = key + ".sparse[" + std::to_string(e) + "]";
      const json& entry = entries[e];
      if (!entry.is_array() || entry.size() != shape.size() + 1)
        fail(where, "expected [" + std::to_string(shape.size()) + " indices, value]");
      int64_t flat = 0;
      for (size_t d = 0; d < shape.size(); ++d) {
        if (!entry[d].is_number_integer())
          fail(where, "expected integer index, got " + entry[d].dump());
        const int64_t index = entry[d].get<int64_t>();
        if (index < 0 || index >= shape[d])
          fail(where, "index " + std::to_string(index) + " out of range [0, " +
                          std::to_string(shape[d]) + ")");
        flat = flat * shape[d] + index;
      }
      if (!entry[shape.size()].is_number())
        fail(where, "expected number, got " + json_type_name(entry[shape.size()]));
      out[static_cast<size_t>(flat)] = entry[shape.size()].get<double>();
    }
  }

  const json& root_;
  std::string path_;
};

// Dense nested list of a tensor (float64 values or int64 values).
json dense_json(const torch::Tensor& tensor) {
  const torch::Tensor t = tensor.contiguous();
  const bool integral = !t.is_floating_point();
  const torch::Tensor flat = integral ? t.to(torch::kInt64) : t.to(torch::kFloat64);
  const auto sizes = t.sizes().vec();
  std::function<json(size_t, int64_t)> build = [&](size_t depth, int64_t offset) -> json {
    json array = json::array();
    int64_t stride = 1;
    for (size_t d = depth + 1; d < sizes.size(); ++d) stride *= sizes[d];
    for (int64_t i = 0; i < sizes[depth]; ++i) {
      if (depth + 1 == sizes.size()) {
        if (integral)
          array.push_back(flat.data_ptr<int64_t>()[offset + i]);
        else
          array.push_back(flat.data_ptr<double>()[offset + i]);
      } else {
        array.push_back(build(depth + 1, offset + i * stride));
      }
    }
    return array;
  };
  return build(0, 0);
}

// Sparse form when at most a quarter of the entries are non-zero (each entry costs rank + 1
// numbers).
json float_array_json(const torch::Tensor& tensor) {
  const torch::Tensor t = tensor.to(torch::kFloat64).contiguous();
  const int64_t nonzero = t.ne(0).sum().item<int64_t>();
  if (nonzero * 4 > t.numel()) return dense_json(t);
  json entries = json::array();
  const double* data = t.data_ptr<double>();
  const auto sizes = t.sizes().vec();
  for (int64_t flat = 0; flat < t.numel(); ++flat) {
    if (data[flat] == 0) continue;
    json entry = json::array();
    std::vector<int64_t> index(sizes.size());
    int64_t rest = flat;
    for (int64_t d = static_cast<int64_t>(sizes.size()) - 1; d >= 0; --d) {
      index[d] = rest % sizes[d];
      rest /= sizes[d];
    }
    for (int64_t i : index) entry.push_back(i);
    entry.push_back(data[flat]);
    entries.push_back(std::move(entry));
  }
  return json{{"shape", sizes}, {"sparse", std::move(entries)}};
}

const std::set<std::string> kRequiredKeys = {
    "format",      "version", "name",     "handedness", "v_template", "faces",       "weights",
    "j_regressor", "parents", "posedirs", "shapedirs",  "hands_mean", "tip_vertices"};
const std::set<std::string> kOptionalKeys = {"vertex_labels", "units", "description"};

}  // namespace

Rig load_rig(const std::string& path) {
  const json root = parse_json_file(path);
  if (!root.is_object()) throw Error(path + ": expected a JSON object at the top level");
  for (const auto& item : root.items())
    if (!kRequiredKeys.count(item.key()) && !kOptionalKeys.count(item.key()))
      throw Error(path + ": unknown key '" + item.key() + "'");
  const RigReader reader(root, path);

  if (reader.string("format") != kFormatName)
    reader.fail("format", "expected \"" + std::string(kFormatName) + "\", got \"" +
                              reader.string("format") + "\"");
  const json& version = reader.get("version");
  if (!version.is_number_integer() || version.get<int64_t>() != kFormatVersion)
    reader.fail("version",
                "expected " + std::to_string(kFormatVersion) + ", got " + version.dump());
  if (root.contains("units") && reader.string("units") != "metres")
    reader.fail("units", "expected \"metres\", got \"" + reader.string("units") + "\"");
  if (root.contains("description")) reader.string("description");

  Rig rig;
  rig.name = reader.string("name");
  const std::string handedness = reader.string("handedness");
  if (handedness == "right")
    rig.handedness = Handedness::right;
  else if (handedness == "left")
    rig.handedness = Handedness::left;
  else
    reader.fail("handedness", "expected \"right\" or \"left\", got \"" + handedness + "\"");

  {
    const json& v = reader.get("v_template");
    if (!v.is_array() || v.empty())
      reader.fail("v_template", "expected a non-empty array of [x, y, z], got " +
                                    (v.is_array() ? std::string("an empty array") : json_type_name(v)));
  }
  const int64_t num_vertices = static_cast<int64_t>(reader.get("v_template").size());
  rig.v_template = reader.floats("v_template", {num_vertices, 3});
  std::vector<int64_t> face_shape = {-1, 3};
  const std::vector<int64_t> faces = reader.integers("faces", face_shape);
  rig.faces = torch::tensor(faces, torch::kInt64).reshape(face_shape);
  rig.weights = reader.floats("weights", {num_vertices, kRigJoints});
  rig.j_regressor = reader.floats("j_regressor", {kRigJoints, num_vertices});
  std::vector<int64_t> parent_shape = {kRigJoints};
  rig.parents = reader.integers("parents", parent_shape);
  rig.posedirs = reader.floats("posedirs", {num_vertices, 3, kPoseFeatureDim});
  rig.shapedirs = reader.floats("shapedirs", {num_vertices, 3, kShapeDim});
  rig.hands_mean = reader.floats("hands_mean", {kPoseDim - 3});
  std::vector<int64_t> tip_shape = {5};
  const std::vector<int64_t> tips = reader.integers("tip_vertices", tip_shape);
  std::copy(tips.begin(), tips.end(), rig.tip_vertices.begin());
  if (root.contains("vertex_labels")) {
    std::vector<int64_t> label_shape = {num_vertices};
    rig.vertex_labels = torch::tensor(reader.integers("vertex_labels", label_shape), torch::kInt64);
  }
  validate_rig(rig, path);
  // A warning, not an error: a rig's geometry is the user's (its regressor's row sums are not
  // checked either), and rigs converted before the converter checked the label still load.
  if (const std::string warning = handedness_disagreement(rig, path); !warning.empty())
    spdlog::warn("{}", warning);
  return rig;
}

void save_rig(const Rig& rig, const std::string& path) {
  validate_rig(rig, path);
  std::vector<std::pair<std::string, json>> entries = {
      {"format", kFormatName},
      {"version", kFormatVersion},
      {"units", "metres"},
      {"name", rig.name},
      {"handedness", rig.handedness == Handedness::left ? "left" : "right"},
      {"parents", rig.parents},
      {"tip_vertices", std::vector<int64_t>(rig.tip_vertices.begin(), rig.tip_vertices.end())},
      {"hands_mean", dense_json(rig.hands_mean.to(torch::kFloat64))},
      {"v_template", dense_json(rig.v_template.to(torch::kFloat64))},
      {"faces", dense_json(rig.faces.to(torch::kInt64))},
      {"weights", float_array_json(rig.weights)},
      {"j_regressor", float_array_json(rig.j_regressor)},
      {"shapedirs", float_array_json(rig.shapedirs)},
      {"posedirs", float_array_json(rig.posedirs)},
  };
  if (rig.vertex_labels.defined())
    entries.emplace_back("vertex_labels", dense_json(rig.vertex_labels.to(torch::kInt64)));
  std::ostringstream out;
  out << "{\n";
  for (size_t i = 0; i < entries.size(); ++i)
    out << "  " << json(entries[i].first).dump() << ": " << entries[i].second.dump()
        << (i + 1 < entries.size() ? ",\n" : "\n");
  out << "}\n";
  write_file_atomic(path, out.str());
}

Rig load_rig_source(const std::string& source) {
  if (source == "builtin" || source == "builtin:right")
    return make_procedural_hand(Handedness::right);
  if (source == "builtin:left") return make_procedural_hand(Handedness::left);
  if (source == kBuiltinFingersRig || source == std::string(kBuiltinFingersRig) + ":right")
    return with_finger_length_modes(make_procedural_hand(Handedness::right));
  if (source == kBuiltinFingersLeftRig) return with_finger_length_modes(make_procedural_hand(Handedness::left));
  if (source.rfind("builtin:", 0) == 0 || source.rfind("builtin+", 0) == 0)
    throw Error("rig source '" + source + "': unknown built-in rig (known: builtin, builtin:right, builtin:left, " +
                kBuiltinFingersRig + ", " + kBuiltinFingersLeftRig + ")");
  return load_rig(source);
}

}  // namespace handscs
