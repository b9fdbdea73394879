// Rig summary and OBJ export: see rig_info.h.
#include "hand/rig_info.h"

#include <ATen/ATen.h>

#include <cstdio>
#include <map>
#include <sstream>

#include "core/atomic_file.h"
#include "hand/joint_order.h"
#include "hand/lbs.h"

namespace handscs {

namespace {
std::string format(const char* fmt, double a, double b, double c) {
  char buffer[128];
  std::snprintf(buffer, sizeof(buffer), fmt, a, b, c);
  return buffer;
}
}  // namespace

std::string describe_rig(const Rig& rig) {
  std::ostringstream out;
  const torch::Tensor v = rig.v_template.to(torch::kFloat64);
  const torch::Tensor lo = std::get<0>(v.min(0)), hi = std::get<0>(v.max(0));
  const torch::Tensor zero = torch::zeros({1, kShapeDim}, torch::kFloat64);
  const LbsOutput rest = lbs(rig, torch::zeros({1, kPoseDim}, torch::kFloat64), zero,
                             torch::zeros({1, 3}, torch::kFloat64), LbsOptions{true});
  const torch::Tensor joints = rest.rest_joints[0];
  out << "name: " << rig.name << "\n";
  out << "handedness: " << (rig.handedness == Handedness::left ? "left" : "right") << "\n";
  out << "vertices: " << rig.num_vertices() << "\n";
  out << "faces: " << rig.faces.size(0) << "\n";
  out << "joints: " << kRigJoints << " (+5 tips = " << kJoints21 << ")\n";
  out << "bounding box min (m): "
      << format("%.4f %.4f %.4f", lo[0].item<double>(), lo[1].item<double>(), lo[2].item<double>())
      << "\n";
  out << "bounding box max (m): "
      << format("%.4f %.4f %.4f", hi[0].item<double>(), hi[1].item<double>(), hi[2].item<double>())
      << "\n";
  const torch::Tensor size = hi - lo;
  out << "extent (m): "
      << format("%.4f %.4f %.4f", size[0].item<double>(), size[1].item<double>(),
                size[2].item<double>())
      << "\n";
  out << "wrist to middle tip (m): "
      << format("%.4f", (joints[18] - joints[0]).norm().item<double>(), 0, 0) << "\n";
  if (rig.vertex_labels.defined()) {
    std::map<int64_t, int64_t> counts;
    const torch::Tensor labels = rig.vertex_labels.to(torch::kInt64).contiguous();
    for (int64_t i = 0; i < labels.numel(); ++i) ++counts[labels.data_ptr<int64_t>()[i]];
    out << "vertex labels:";
    for (const auto& [label, count] : counts) out << " " << label << ":" << count;
    out << "\n";
  }
  out << "rest joints (MANO21, m):\n";
  for (int j = 0; j < kJoints21; ++j)
    out << "  " << j << " " << kMano21Names[j] << ": "
        << format("%.4f %.4f %.4f", joints[j][0].item<double>(), joints[j][1].item<double>(),
                  joints[j][2].item<double>())
        << "\n";
  return out.str();
}

void write_rig_obj(const Rig& rig, const std::string& path) {
  std::ostringstream out;
  out.precision(9);
  out << "# " << rig.name << " template (metres)\n";
  const torch::Tensor v = rig.v_template.to(torch::kFloat64).contiguous();
  const torch::Tensor f = rig.faces.to(torch::kInt64).contiguous();
  const double* p = v.data_ptr<double>();
  for (int64_t i = 0; i < v.size(0); ++i)
    out << "v " << p[3 * i] << " " << p[3 * i + 1] << " " << p[3 * i + 2] << "\n";
  const int64_t* faces = f.data_ptr<int64_t>();
  for (int64_t i = 0; i < f.size(0); ++i)
    out << "f " << faces[3 * i] + 1 << " " << faces[3 * i + 1] + 1 << " " << faces[3 * i + 2] + 1
        << "\n";
  write_file_atomic(path, out.str());
}

}  // namespace handscs
