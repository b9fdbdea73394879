#include "synth/tissue.h"

#include <algorithm>
#include <cmath>

#include "hand/joint_order.h"
#include "synth/tensor_row.h"

namespace handscs {

using namespace synth;

namespace {

// Joint sizes (m): the radius over which a joint's skin responds to its flexion.
constexpr double kJointRadius[3] = {0.009, 0.007, 0.006};
// Half-width of the crease fold along the bone (m) and its reach around the joint (m).
constexpr double kFoldWidth = 0.0015, kFoldReach = 0.012;
// Facing test of contact: normals at least this opposed (cos 120 degrees).
constexpr double kFacingCos = -0.5;
constexpr double kMm = 1e-3;

double smooth_side(double x) {  // 0 for x <= -0.3, 1 for x >= 0.3, smooth between
  const double t = std::clamp((x + 0.3) / 0.6, 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

}  // namespace

TissueRig make_tissue_rig(const Rig& rig, const HandAxes& axes) {
  TissueRig t;
  const torch::Tensor vt = rig.v_template.to(torch::kFloat64).contiguous();
  const torch::Tensor joints = torch::matmul(rig.j_regressor.to(torch::kFloat64), vt).contiguous();
  const torch::Tensor owner = rig.weights.argmax(1).to(torch::kInt64).contiguous();
  const int64_t n = vt.size(0);
  for (int j = 0; j < 16; ++j) t.joints[j] = tensor_row(joints, j);
  std::array<int, 16> finger_of{};
  finger_of.fill(5);
  for (int f = 0; f < kFingers; ++f)
    for (int k = 0; k < 3; ++k) {
      finger_of[kFingerJoints[f][k]] = f;
      const Vec3 end =
          k < 2 ? t.joints[kFingerJoints[f][k + 1]] : tensor_row(vt, rig.tip_vertices[f]);
      t.bone_dir[f][k] = normalized(end - t.joints[kFingerJoints[f][k]]);
    }
  t.wrist = t.joints[0];
  const Vec3 knuckles = (t.joints[1] + t.joints[4] + t.joints[10] + t.joints[7]) * 0.25;
  t.palm_long = normalized(knuckles - t.wrist);
  t.palm_length = norm(knuckles - t.wrist);
  t.palm_normal = axes.palm_normal;
  const Vec3 thumb = t.joints[13] - t.wrist;
  t.palm_across = normalized(thumb - t.palm_long * dot(thumb, t.palm_long));
  t.palm_width = std::max(1e-3, std::fabs(dot(t.joints[1] - t.joints[7], t.palm_across)));
  const int64_t* o = owner.data_ptr<int64_t>();
  t.rest.resize(n);
  t.part.resize(n);
  t.palmar.resize(n);
  for (int64_t i = 0; i < n; ++i) {
    t.rest[i] = tensor_row(vt, i);
    const int joint = static_cast<int>(o[i]);
    t.part[i] = finger_of[joint];
    // Palmar side relative to the owning bone's axis: the offset from the bone, against the
    // palmar direction (the thumb's own for the thumb).
    const Vec3 palmar_dir = t.part[i] == kThumb ? axes.thumb_palmar : axes.palm_normal;
    const Vec3 offset = t.rest[i] - t.joints[joint];
    Vec3 radial = offset;
    if (t.part[i] < 5) {
      const int k = static_cast<int>(std::find(kFingerJoints[t.part[i]].begin(),
                                               kFingerJoints[t.part[i]].end(), joint) -
                                     kFingerJoints[t.part[i]].begin());
      const Vec3 d = t.bone_dir[t.part[i]][k];
      radial = offset - d * dot(offset, d);
    }
    t.palmar[i] = smooth_side(dot(normalized(radial), palmar_dir));
  }
  return t;
}

TissueResult tissue_displacement(const TissueRig& t, const SynthEffects& e,
                                 const HandArticulation& a, const std::vector<float>& vertices,
                                 const std::vector<float>& normals) {
  const size_t n = t.rest.size();
  TissueResult result;
  result.displacement.assign(n, 0.0f);
  result.contact.assign(n, 0.0f);
  const double opposition = std::clamp(a.thumb_opposition / kFullOpposition, 0.0, 1.0);
  const double cup = palm_fold(a);
  for (size_t i = 0; i < n; ++i) {
    const Vec3& x = t.rest[i];
    const double palmar = t.palmar[i], dorsal = 1 - palmar;
    double d = 0;
    for (int f = 0; f < kFingers; ++f)
      for (int k = 0; k < 3; ++k) {
        const double flex = std::clamp(a.flex[f][k] / kFlexionUnit, 0.0, 1.2);
        if (flex <= 0) continue;
        const Vec3 offset = x - t.joints[kFingerJoints[f][k]];
        const double r2 = dot(offset, offset);
        const double r = kJointRadius[k];
        if (r2 > 16 * kFoldReach * kFoldReach) continue;
        const double g = std::exp(-r2 / (r * r));
        const double s = dot(offset, t.bone_dir[f][k]);
        const double fold = std::exp(-s * s / (kFoldWidth * kFoldWidth)) *
                            std::exp(-r2 / (kFoldReach * kFoldReach));
        // The thumb's MCP-like base (CMC) sits inside the palm: no knuckle there.
        const double bulge = f == kThumb && k == 0 ? 0.0 : e.knuckle_bulge_mm;
        d += flex * kMm * (bulge * dorsal * g - e.flexed_side_mm * palmar * g -
                           e.crease_fold_mm * palmar * fold);
      }
    if (t.part[i] == 5 || t.part[i] == kThumb) {
      const Vec3 q = x - t.wrist;
      const double l = dot(q, t.palm_long) / t.palm_length;
      const double c = dot(q, t.palm_across) / t.palm_width;
      const double palm_centre = std::exp(-((l - 0.55) * (l - 0.55) / 0.09 + c * c / 0.16));
      const double thenar =
          std::exp(-((l - 0.3) * (l - 0.3) / 0.04 + (c - 0.55) * (c - 0.55) / 0.0625));
      d += kMm * (-e.palm_cup_mm * cup * palmar * palm_centre +
                  e.thenar_bulge_mm * opposition * palmar * thenar);
    }
    result.displacement[i] = static_cast<float>(d);
  }
  // Contact on the displaced surface: vertices of different parts facing each other.
  const double radius = e.contact_radius_mm * kMm;
  if (radius > 0 && e.contact_max_mm > 0) {
    std::vector<Vec3> p(n), nn(n);
    for (size_t i = 0; i < n; ++i) {
      nn[i] = {normals[i * 3], normals[i * 3 + 1], normals[i * 3 + 2]};
      p[i] = Vec3{vertices[i * 3], vertices[i * 3 + 1], vertices[i * 3 + 2]} +
             nn[i] * result.displacement[i];
    }
    for (size_t i = 0; i < n; ++i) {
      double gap = radius;
      for (size_t j = 0; j < n; ++j) {
        if (t.part[j] == t.part[i] || dot(nn[i], nn[j]) > kFacingCos) continue;
        const Vec3 offset = p[j] - p[i];
        const double dist = norm(offset);
        if (dist >= gap || dot(offset, nn[i]) <= 0) continue;
        gap = dist;
      }
      if (gap < radius) {
        const double u = 1 - gap / radius;
        result.contact[i] = static_cast<float>(e.contact_max_mm * kMm * u * u);
        result.displacement[i] -= result.contact[i];
      }
    }
  }
  return result;
}

void apply_displacement(const TissueResult& result, const std::vector<float>& normals,
                        std::vector<float>& vertices) {
  for (size_t i = 0; i < result.displacement.size(); ++i)
    for (int d = 0; d < 3; ++d) vertices[i * 3 + d] += result.displacement[i] * normals[i * 3 + d];
}

}  // namespace handscs
