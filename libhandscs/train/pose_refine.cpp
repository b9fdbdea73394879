#include "train/pose_refine.h"

#include <cmath>
#include <sstream>

#include <torch/types.h>

#include "core/error.h"

namespace handscs {

namespace {
// Adam's constants for the corrections: the values of Kingma and Ba (the avatar's Adam uses 3DGS's
// eps of 1e-15 for tiny Gaussians' gradients; a pose gradient is not tiny).
constexpr double kBeta1 = 0.9, kBeta2 = 0.999, kEps = 1e-8;
constexpr double kDegreesPerRadian = 180.0 / M_PI;
}  // namespace

PoseCorrections::PoseCorrections(int64_t num_poses, const PoseRefineConfig& config)
    : config_(config) {
  require(num_poses >= 0, "pose refinement: negative pose count");
  const auto options = torch::TensorOptions().dtype(torch::kFloat64);
  values_ = torch::zeros({num_poses, kWidth}, options);
  exp_avg_ = torch::zeros({num_poses, kWidth}, options);
  exp_avg_sq_ = torch::zeros({num_poses, kWidth}, options);
  steps_ = torch::zeros({num_poses}, torch::kInt64);
}

CorrectedPose PoseCorrections::apply(int64_t row, const torch::Tensor& pose,
                                     const torch::Tensor& trans, bool learn) const {
  require(row >= 0 && row < rows(), "pose refinement: pose index " + std::to_string(row) +
                                        " outside 0.." + std::to_string(rows() - 1));
  CorrectedPose out;
  out.delta = values_[row].to(pose.scalar_type()).clone();
  if (learn) out.delta.requires_grad_(true);
  out.pose = pose.reshape({48}) + out.delta.slice(0, 0, 48);
  out.trans = trans.reshape({3}) + kTransUnit * out.delta.slice(0, 48, kWidth);
  return out;
}

torch::Tensor PoseCorrections::penalty(const torch::Tensor& delta) const {
  return config_.reg * delta.pow(2).sum();
}

void PoseCorrections::step(int64_t row, const torch::Tensor& grad) {
  require(row >= 0 && row < rows(), "pose refinement: pose index out of range");
  torch::NoGradGuard no_grad;
  const auto g = grad.detach().to(torch::kFloat64).reshape({kWidth});
  auto m = exp_avg_[row];
  auto v = exp_avg_sq_[row];
  m.mul_(kBeta1).add_(g, 1 - kBeta1);
  v.mul_(kBeta2).addcmul_(g, g, 1 - kBeta2);
  const int64_t t = steps_[row].item<int64_t>() + 1;
  steps_[row] = t;
  const double m_hat = 1.0 / (1.0 - std::pow(kBeta1, static_cast<double>(t)));
  const double v_hat = 1.0 / (1.0 - std::pow(kBeta2, static_cast<double>(t)));
  values_[row].sub_(config_.lr * m_hat * m / ((v * v_hat).sqrt() + kEps));
}

std::map<std::string, double> PoseCorrections::summary() const {
  torch::NoGradGuard no_grad;
  std::map<std::string, double> out{{"pose_refine_deg", 0.0}, {"pose_refine_global_deg", 0.0},
                                    {"pose_refine_mm", 0.0}};
  const auto updated = steps_.gt(0).nonzero().reshape({-1});
  if (updated.numel() == 0) return out;
  const auto rows = values_.index_select(0, updated);
  // Rotation angle of a joint's correction = the length of its axis-angle vector.
  const auto joints = rows.slice(1, 3, 48).reshape({-1, 15, 3}).pow(2).sum(2);  // angle^2
  const auto global = rows.slice(1, 0, 3).pow(2).sum(1);
  const auto trans = rows.slice(1, 48, kWidth).pow(2).sum(1) * (kTransUnit * kTransUnit);
  out["pose_refine_deg"] = joints.mean().sqrt().item<double>() * kDegreesPerRadian;
  out["pose_refine_global_deg"] = global.mean().sqrt().item<double>() * kDegreesPerRadian;
  out["pose_refine_mm"] = trans.mean().sqrt().item<double>() * 1000.0;
  return out;
}

std::string PoseCorrections::to_csv() const {
  std::ostringstream out;
  out << "pose_index,steps,joint_rms_deg,global_deg,trans_mm";
  for (int k = 0; k < 48; ++k) out << ",pose_" << k;
  out << ",trans_x_m,trans_y_m,trans_z_m\n";
  out.precision(9);
  const auto values = values_.contiguous();
  const double* v = values.data_ptr<double>();
  for (int64_t r = 0; r < rows(); ++r) {
    const int64_t steps = steps_[r].item<int64_t>();
    if (steps == 0) continue;
    const double* d = v + r * kWidth;
    double joints = 0, global = 0, trans = 0;
    for (int k = 3; k < 48; ++k) joints += d[k] * d[k];
    for (int k = 0; k < 3; ++k) global += d[k] * d[k];
    for (int k = 48; k < kWidth; ++k) trans += d[k] * d[k];
    out << r << "," << steps << "," << std::sqrt(joints / 15) * kDegreesPerRadian << ","
        << std::sqrt(global) * kDegreesPerRadian << "," << std::sqrt(trans) * kTransUnit * 1000;
    for (int k = 0; k < 48; ++k) out << "," << d[k];
    for (int k = 48; k < kWidth; ++k) out << "," << d[k] * kTransUnit;
    out << "\n";
  }
  return out.str();
}

std::map<std::string, torch::Tensor> PoseCorrections::state() const {
  return {{"pose_refine/values", values_.clone()},
          {"pose_refine/exp_avg", exp_avg_.clone()},
          {"pose_refine/exp_avg_sq", exp_avg_sq_.clone()},
          {"pose_refine/steps", steps_.clone()}};
}

void PoseCorrections::load_state(const std::map<std::string, torch::Tensor>& state,
                                 const std::string& source) {
  auto take = [&](const std::string& name, const torch::Tensor& like) {
    const auto it = state.find(name);
    if (it == state.end()) throw Error(source + ": checkpoint lacks " + name);
    if (it->second.sizes() != like.sizes())
      throw Error(source + ": " + name + " has " + std::to_string(it->second.size(0)) +
                  " rows, the capture has " + std::to_string(like.size(0)) + " poses");
    return it->second.to(like.scalar_type()).clone();
  };
  auto values = take("pose_refine/values", values_);
  auto exp_avg = take("pose_refine/exp_avg", exp_avg_);
  auto exp_avg_sq = take("pose_refine/exp_avg_sq", exp_avg_sq_);
  auto steps = take("pose_refine/steps", steps_);
  values_ = values, exp_avg_ = exp_avg, exp_avg_sq_ = exp_avg_sq, steps_ = steps;
}

}  // namespace handscs
