#include "synth/render.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "data/camera_transforms.h"
#include "data/mesh_mask.h"
#include "data/mesh_raster.h"
#include "synth/motion.h"
#include "synth/regions.h"

#include <opencv2/imgproc.hpp>

namespace handscs {

using namespace synth;

namespace {
// Fixed studio lights (world directions towards the lights) and ambient: a key light from the
// palm/thumb/fingertip side and a weaker fill from the back, so every side is lit but differently.
const Vec3 kKeyLight = normalized({-0.35, -0.55, 0.75});
const Vec3 kFillLight = normalized({0.4, 0.8, -0.45});
constexpr double kAmbient = 0.30, kKey = 0.62, kFill = 0.28;
constexpr double kFoldDarkening = 0.55;  // fully occluded folds keep 45% of their light
// Background: dark grey-blue (display levels 0-255) with Gaussian noise of 1.6 levels.
constexpr double kBackground[3] = {8.0, 6.0, 5.0};  // B, G, R
constexpr double kBackgroundNoise = 1.6;
}  // namespace

Vec3 key_light_direction() { return kKeyLight; }

SynthView render_synth_view(const SynthSkin& skin, const SynthMeshView& mesh, const Camera& camera,
                            int supersample, uint64_t noise_seed, bool background_noise) {
  require(supersample >= 1 && supersample % 2 == 1, "render_synth_view: supersample must be odd");
  const int s = supersample;
  const int width = camera.width, height = camera.height;
  SynthView view;
  view.bgr.create(height, width, CV_8UC3);
  view.coverage = cv::Mat(height, width, CV_8UC1, cv::Scalar(0));
  view.samples = cv::Mat(height, width, CV_8UC1, cv::Scalar(0));
  view.radiance.create(height, width, CV_32FC3);
  view.regions = cv::Mat(height, width, CV_8UC1, cv::Scalar(0));
  const std::vector<float>& texture = mesh.texture ? *mesh.texture : skin.canonical;
  const std::vector<float>& nails = mesh.nail ? *mesh.nail : skin.nail;
  const std::vector<float>& palmars = mesh.palmar ? *mesh.palmar : skin.palmar;

  // Background everywhere first (noise stream in raster order: independent of the hand).
  // Noise ~ N(0, 1) approximated by the sum of four uniforms (Irwin-Hall, variance 1/3 each):
  // no transcendental functions per pixel.
  SynthRandom random(noise_seed);
  std::vector<float> background(static_cast<size_t>(width) * height * 3);
  const double irwin_hall_scale = std::sqrt(3.0);
  for (size_t i = 0; i < background.size(); ++i) {
    if (!background_noise) {
      background[i] = static_cast<float>(kBackground[i % 3]);
      continue;
    }
    const double gauss =
        (random.uniform() + random.uniform() + random.uniform() + random.uniform() - 2.0) *
        irwin_hall_scale;
    background[i] = static_cast<float>(kBackground[i % 3] + kBackgroundNoise * gauss);
  }

  const std::vector<float>& vertices = *mesh.vertices;
  const std::vector<int64_t>& faces = *mesh.faces;
  const int64_t num_vertices = static_cast<int64_t>(vertices.size() / 3);
  const Camera fine = scale_camera(camera, s);
  const PixelRect bounds = projected_bounds(vertices.data(), num_vertices, fine);
  MeshRaster raster;
  if (!bounds.empty()) {
    // Whole output pixels only, so every pixel has all its sub-samples rasterised.
    const PixelRect aligned{bounds.x0 / s * s, bounds.y0 / s * s,
                            std::min(fine.width, (bounds.x1 + s - 1) / s * s),
                            std::min(fine.height, (bounds.y1 + s - 1) / s * s)};
    rasterize_mesh(vertices.data(), num_vertices, faces.data(),
                   static_cast<int64_t>(faces.size() / 3), fine, aligned, true, raster);
  }
  const PixelRect& r = raster.rect;
  const int centre = s / 2;
  for (int y = 0; y < height; ++y) {
    uint8_t* out = view.bgr.ptr<uint8_t>(y);
    float* radiance = view.radiance.ptr<float>(y);
    for (int x = 0; x < width; ++x) {
      const float* bg = &background[(static_cast<size_t>(y) * width + x) * 3];
      double sum[3] = {0, 0, 0};
      int hits = 0;
      const bool inside = !raster.face.empty() && x * s >= r.x0 && (x + 1) * s <= r.x1 &&
                          y * s >= r.y0 && (y + 1) * s <= r.y1;
      if (inside) {
        for (int sy = 0; sy < s; ++sy)
          for (int sx = 0; sx < s; ++sx) {
            const int fx = x * s + sx, fy = y * s + sy;
            const size_t index = static_cast<size_t>(fy - r.y0) * r.width() + (fx - r.x0);
            const int32_t face = raster.face[index];
            if (face < 0) continue;
            ++hits;
            if (sx == centre && sy == centre) view.coverage.at<uint8_t>(y, x) = 1;
            const float* b = &raster.bary[index * 3];
            Vec3 n{0, 0, 0}, p{0, 0, 0};
            double nail = 0, palmar = 0, occ = 0, visible = 0, contact = 0;
            for (int k = 0; k < 3; ++k) {
              const int64_t v = faces[face * 3 + k];
              for (int d = 0; d < 3; ++d) {
                n[d] += b[k] * (*mesh.normals)[v * 3 + d];
                p[d] += b[k] * texture[v * 3 + d];
              }
              nail += b[k] * nails[v];
              palmar += b[k] * palmars[v];
              occ += b[k] * (*mesh.occlusion)[v];
              visible += b[k] * (mesh.visibility ? (*mesh.visibility)[v] : 1.0f);
              if (mesh.contact) contact += b[k] * (*mesh.contact)[v];
            }
            n = normalized(n);
            const double facing = dot(n, kKeyLight);
            const double light = kAmbient + kKey * visible * std::max(0.0, facing) +
                                 kFill * std::max(0.0, dot(n, kFillLight));
            double crease = 0;
            const SkinFlexion* flexion =
                face >= mesh.second_hand_face ? mesh.second_flexion : mesh.flexion;
            const Vec3 albedo = skin_albedo(skin, p, nail, palmar, flexion, &crease);
            const double shade = light * (1 - kFoldDarkening * std::clamp(occ, 0.0, 1.0)) * 255.0;
            sum[0] += albedo[2] * shade;  // BGR
            sum[1] += albedo[1] * shade;
            sum[2] += albedo[0] * shade;
            if (sx == centre && sy == centre) {
              uint8_t bits = 0;
              if (crease > kCreaseThreshold) bits |= kRegionCrease;
              if (contact > kContactThreshold || occ > kOcclusionThreshold) bits |= kRegionContact;
              if (mesh.visibility && visible < kShadowThreshold && facing > kFacingThreshold)
                bits |= kRegionShadow;
              view.regions.at<uint8_t>(y, x) = bits;
            }
          }
      }
      const int misses = s * s - hits;
      for (int c = 0; c < 3; ++c) {
        const double value = (sum[c] + misses * bg[c]) / (s * s);
        radiance[x * 3 + c] = static_cast<float>(value);
        out[x * 3 + c] = static_cast<uint8_t>(std::clamp(std::lround(value), 0L, 255L));
      }
      view.samples.at<uint8_t>(y, x) = static_cast<uint8_t>(hits);
    }
  }
  // Dilate each bit by one pixel (max over the 3x3 neighbourhood is the OR of the bits' dilations).
  cv::Mat dilated = cv::Mat::zeros(height, width, CV_8UC1);
  for (uint8_t bit : {kRegionCrease, kRegionContact, kRegionShadow}) {
    cv::Mat plane = (view.regions & bit) / bit, grown;
    cv::dilate(plane, grown, cv::Mat::ones(3, 3, CV_8UC1));
    dilated |= grown * bit;
  }
  view.regions = dilated;
  return view;
}

}  // namespace handscs
