#include "train/camera_color.h"

#include <algorithm>
#include <sstream>

#include <spdlog/spdlog.h>
#include <torch/types.h>

#include "core/error.h"

namespace handscs {

namespace {
using Mode = TrainConfig::CameraColor;

// Where the diagonal of A sits in a row of parameters (the gains), and where the bias starts.
std::vector<int64_t> diagonal_columns(Mode mode) {
  if (mode == Mode::gain) return {0, 1, 2};
  if (mode == Mode::affine) return {0, 4, 8};
  return {};
}
int64_t bias_column(Mode mode) { return mode == Mode::affine ? 9 : 3; }
}  // namespace

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
  const auto bias = params.slice(1, bias_column(mode), bias_column(mode) + 3).unsqueeze(2);
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

CameraColors::CameraColors(Mode mode, std::vector<std::string> camera_ids)
    : mode_(mode), camera_ids_(std::move(camera_ids)) {
  require(mode_ != Mode::off, "camera colour: no transforms with train.camera_color = off");
  require(!camera_ids_.empty(), "camera colour: no training cameras");
  params_ = torch::zeros({static_cast<int64_t>(camera_ids_.size()), camera_color_width(mode_)})
                .requires_grad_(true);
}

int64_t CameraColors::row(const std::string& camera_id) const {
  const auto it = std::find(camera_ids_.begin(), camera_ids_.end(), camera_id);
  return it == camera_ids_.end() ? -1 : static_cast<int64_t>(it - camera_ids_.begin());
}

torch::Tensor CameraColors::matrix(int64_t row) const {
  require(row >= 0 && row < params_.size(0), "camera colour: row out of range");
  return camera_color_matrices(mode_, params_.slice(0, row, row + 1))[0];
}

torch::Tensor CameraColors::penalty(double weight) const { return weight * params_.pow(2).sum(); }

void CameraColors::project(bool warn) {
  torch::NoGradGuard no_grad;
  const auto lower = torch::full({camera_color_width(mode_)}, -kMaxBias);
  auto upper = torch::full({camera_color_width(mode_)}, kMaxBias);
  if (mode_ == Mode::affine) {
    lower.slice(0, 0, 9).fill_(-kMaxCross);
    upper.slice(0, 0, 9).fill_(kMaxCross);
  }
  for (const int64_t k : diagonal_columns(mode_)) {
    lower[k] = kMinGain - 1;
    upper[k] = kMaxGain - 1;
  }
  const auto outside = params_.lt(lower).logical_or(params_.gt(upper));
  if (outside.any().item<bool>()) {
    const auto diagonal = diagonal_columns(mode_);
    const auto rows = outside.any(1).nonzero().reshape({-1});
    for (int64_t i = 0; i < rows.numel(); ++i) {
      const int64_t r = rows[i].item<int64_t>();
      for (int64_t k = 0; k < params_.size(1); ++k) {
        if (!outside[r][k].item<bool>()) continue;
        const bool gain = std::count(diagonal.begin(), diagonal.end(), k) > 0;
        const std::string kind = gain ? "gain" : k >= bias_column(mode_) ? "bias" : "cross term";
        const std::string key = camera_ids_[r] + "/" + kind;
        if (std::count(warned_.begin(), warned_.end(), key)) continue;
        warned_.push_back(key);
        if (!warn) continue;
        const double value = params_[r][k].item<double>() + (gain ? 1.0 : 0.0);
        const double bound = kind == "bias" ? kMaxBias : kMaxCross;
        spdlog::warn(
            "camera {}: its colour transform runs away ({} {:.3f} outside [{:g}, {:g}]); held at "
            "the range's edge. A camera whose images are grey or dark is no colour response: drop "
            "it (data.drop_monochrome, data.train_cameras) or check its images",
            camera_ids_[r], kind, value, gain ? kMinGain : -bound, gain ? kMaxGain : bound);
      }
    }
    params_.copy_(torch::max(torch::min(params_, upper), lower));
  }
  params_.sub_(params_.mean(0, /*keepdim=*/true));
}

std::map<std::string, double> CameraColors::summary() const {
  torch::NoGradGuard no_grad;
  std::map<std::string, double> out;
  const auto m = camera_color_matrices(mode_, params_.detach());
  for (size_t r = 0; r < camera_ids_.size(); ++r)
    out[camera_ids_[r]] = m[static_cast<int64_t>(r)].slice(1, 0, 3).diagonal().mean().item<double>();
  return out;
}

std::string CameraColors::to_csv() const {
  std::ostringstream out;
  out << "camera_id";
  for (const char* row : {"r", "g", "b"})
    for (const char* column : {"r", "g", "b", "bias"}) out << "," << row << "_" << column;
  out << "\n";
  out.precision(9);
  const auto m = camera_color_matrices(mode_, params_.detach()).to(torch::kFloat64).contiguous();
  const double* v = m.data_ptr<double>();
  for (size_t r = 0; r < camera_ids_.size(); ++r) {
    out << camera_ids_[r];
    for (int k = 0; k < 12; ++k) out << "," << v[r * 12 + k];
    out << "\n";
  }
  return out.str();
}

void CameraColors::store(Checkpoint& checkpoint) const {
  checkpoint.tensors["camera_color/params"] = params_.detach().clone();
  checkpoint.meta["camera_color"] = {{"mode", camera_color_name(mode_)}, {"cameras", camera_ids_}};
}

bool CameraColors::load(const Checkpoint& checkpoint, const std::string& source) {
  const auto it = checkpoint.tensors.find("camera_color/params");
  if (it == checkpoint.tensors.end() || !checkpoint.meta.contains("camera_color")) return false;
  const auto& meta = checkpoint.meta.at("camera_color");
  const std::string mode = meta.value("mode", "");
  if (mode != camera_color_name(mode_))
    throw Error(source + ": its colour transforms are " + mode + ", the config asks for " +
                camera_color_name(mode_) + " (train.camera_color); resume with " + mode);
  const auto ids = meta.at("cameras").get<std::vector<std::string>>();
  const auto& stored = it->second;
  if (stored.dim() != 2 || stored.size(0) != static_cast<int64_t>(ids.size()) ||
      stored.size(1) != camera_color_width(mode_))
    throw Error(source + ": camera_color/params has shape " + c10::str(stored.sizes()) + " for " +
                std::to_string(ids.size()) + " cameras");
  torch::NoGradGuard no_grad;
  params_.zero_();
  for (size_t k = 0; k < ids.size(); ++k) {
    const int64_t r = row(ids[k]);
    if (r < 0) {
      spdlog::warn("{}: camera {} has a colour transform but is no training camera now; ignored",
                   source, ids[k]);
      continue;
    }
    params_[r].copy_(stored[static_cast<int64_t>(k)]);
  }
  return true;
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
