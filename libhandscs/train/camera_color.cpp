#include "train/camera_color.h"

#include <algorithm>
#include <sstream>

#include <spdlog/spdlog.h>
#include <torch/types.h>

#include "core/error.h"

namespace handscs {

namespace {
using Mode = TrainConfig::CameraColor;
}  // namespace

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
  for (const int64_t k : camera_color_diagonal_columns(mode_)) {
    lower[k] = kMinGain - 1;
    upper[k] = kMaxGain - 1;
  }
  const auto outside = params_.lt(lower).logical_or(params_.gt(upper));
  if (outside.any().item<bool>()) {
    const auto diagonal = camera_color_diagonal_columns(mode_);
    const auto rows = outside.any(1).nonzero().reshape({-1});
    for (int64_t i = 0; i < rows.numel(); ++i) {
      const int64_t r = rows[i].item<int64_t>();
      for (int64_t k = 0; k < params_.size(1); ++k) {
        if (!outside[r][k].item<bool>()) continue;
        const bool gain = std::count(diagonal.begin(), diagonal.end(), k) > 0;
        const std::string kind =
            gain ? "gain" : k >= camera_color_bias_column(mode_) ? "bias" : "cross term";
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

}  // namespace handscs
