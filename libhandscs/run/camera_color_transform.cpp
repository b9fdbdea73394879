#include "run/camera_color_transform.h"

#include "core/error.h"

namespace handscs {

namespace {
using Mode = TrainConfig::CameraColor;
}  // namespace

std::vector<int64_t> camera_color_diagonal_columns(Mode mode) {
  if (mode == Mode::gain) return {0, 1, 2};
  if (mode == Mode::affine) return {0, 4, 8};
  return {};
}

int64_t camera_color_bias_column(Mode mode) { return mode == Mode::affine ? 9 : 3; }

int64_t camera_color_width(Mode mode) {
  switch (mode) {
    case Mode::gain: return 6;
    case Mode::affine: return 12;
    case Mode::off: break;
  }
  return 0;
}

std::string camera_color_name(Mode mode) {
  switch (mode) {
    case Mode::gain: return "gain";
    case Mode::affine: return "affine";
    case Mode::off: break;
  }
  return "off";
}

torch::Tensor camera_color_matrices(Mode mode, const torch::Tensor& params) {
  require(params.dim() == 2 && params.size(1) == camera_color_width(mode),
          "camera colour: parameters of shape " + c10::str(params.sizes()) + " for mode " +
              camera_color_name(mode));
  const int64_t c = params.size(0);
  const auto eye = torch::eye(3, params.options()).expand({c, 3, 3});
  const int64_t bias_start = camera_color_bias_column(mode);
  const auto bias = params.slice(1, bias_start, bias_start + 3).unsqueeze(2);
  const auto a = mode == Mode::gain ? eye + torch::diag_embed(params.slice(1, 0, 3))
                                    : eye + params.slice(1, 0, 9).reshape({c, 3, 3});
  return torch::cat({a, bias}, 2);
}

torch::Tensor apply_color_transform(const torch::Tensor& rgb, const torch::Tensor& alpha,
                                    const std::array<float, 3>& background,
                                    const torch::Tensor& matrix) {
  const auto bg = torch::tensor({background[0], background[1], background[2]}, rgb.options());
  const auto a = matrix.slice(1, 0, 3);
  const auto b = matrix.select(1, 3);
  const auto cover = alpha.unsqueeze(2);
  const auto uncovered = (1 - cover) * bg;  // the background's share of each pixel
  return torch::matmul(rgb - uncovered, a.transpose(0, 1)) + cover * b + uncovered;
}

std::optional<torch::Tensor> CameraColorTable::find(const std::string& camera_id) const {
  const auto it = matrices.find(camera_id);
  if (it == matrices.end()) return std::nullopt;
  return it->second;
}

CameraColorTable CameraColorTable::from_checkpoint(const Checkpoint& checkpoint,
                                                   const std::string& source) {
  CameraColorTable table;
  const auto it = checkpoint.tensors.find("camera_color/params");
  if (it == checkpoint.tensors.end() || !checkpoint.meta.contains("camera_color")) return table;
  const auto& meta = checkpoint.meta.at("camera_color");
  const std::string mode = meta.value("mode", "");
  if (mode == "gain")
    table.mode = Mode::gain;
  else if (mode == "affine")
    table.mode = Mode::affine;
  else
    throw Error(source + ": unknown colour transform mode '" + mode + "'");
  const auto ids = meta.at("cameras").get<std::vector<std::string>>();
  if (it->second.dim() != 2 || it->second.size(0) != static_cast<int64_t>(ids.size()))
    throw Error(source + ": camera_color/params does not match its " + std::to_string(ids.size()) +
                " cameras");
  const auto m = camera_color_matrices(table.mode, it->second.to(torch::kFloat32));
  for (size_t k = 0; k < ids.size(); ++k) table.matrices[ids[k]] = m[static_cast<int64_t>(k)].clone();
  return table;
}

}  // namespace handscs
