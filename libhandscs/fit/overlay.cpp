#include "fit/overlay.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "core/vec3.h"

namespace handscs {

namespace {

// Mesh opacity over the photograph: half, so the skin under it stays visible.
constexpr double kMeshOpacity = 0.5;

}  // namespace

cv::Mat draw_overlay(const cv::Mat& photo, const Camera& camera, const std::vector<OverlayHand>& hands,
                     int margin_px) {
  cv::Mat mesh_layer = photo.clone();
  struct Face {
    double depth;
    std::array<cv::Point, 3> corners;
    cv::Scalar colour;
  };
  std::vector<Face> faces;
  int x0 = photo.cols, y0 = photo.rows, x1 = 0, y1 = 0;
  for (const OverlayHand& hand : hands) {
    const auto v = hand.vertices.to(torch::kFloat64).contiguous();
    const double* vp = v.data_ptr<double>();
    const auto f = hand.rig->faces.contiguous();
    const int64_t* fp = f.data_ptr<int64_t>();
    const int64_t nv = v.size(0);
    std::vector<std::array<double, 3>> cam(nv);
    std::vector<cv::Point2d> px(nv);
    for (int64_t i = 0; i < nv; ++i) {
      cam[i] = camera.to_camera({vp[3 * i], vp[3 * i + 1], vp[3 * i + 2]});
      const auto uv = camera.project_camera(cam[i]);
      px[i] = {uv[0], uv[1]};
    }
    for (int64_t t = 0; t < f.size(0); ++t) {
      const int64_t a = fp[3 * t], b = fp[3 * t + 1], c = fp[3 * t + 2];
      if (!(cam[a][2] > 0 && cam[b][2] > 0 && cam[c][2] > 0)) continue;
      const Vec3 n = normalized(cross(Vec3(cam[b]) - Vec3(cam[a]), Vec3(cam[c]) - Vec3(cam[a])));
      const Vec3 centre = (Vec3(cam[a]) + Vec3(cam[b]) + Vec3(cam[c])) * (1.0 / 3.0);
      // Lambert shading with the light at the camera; back faces (n towards +z) darker.
      const double shade = 0.35 + 0.65 * std::fabs(dot(n, normalized(centre)));
      Face face{centre[2], {}, hand.colour * shade};
      const int64_t ids[3] = {a, b, c};
      for (int k = 0; k < 3; ++k) {
        face.corners[k] = cv::Point(static_cast<int>(std::lround(px[ids[k]].x - 0.5)),
                                    static_cast<int>(std::lround(px[ids[k]].y - 0.5)));
        x0 = std::min(x0, face.corners[k].x);
        y0 = std::min(y0, face.corners[k].y);
        x1 = std::max(x1, face.corners[k].x);
        y1 = std::max(y1, face.corners[k].y);
      }
      faces.push_back(face);
    }
  }
  std::sort(faces.begin(), faces.end(), [](const Face& a, const Face& b) { return a.depth > b.depth; });
  for (const Face& face : faces) cv::fillConvexPoly(mesh_layer, face.corners.data(), 3, face.colour, cv::LINE_AA);
  cv::Mat out;
  cv::addWeighted(mesh_layer, kMeshOpacity, photo, 1.0 - kMeshOpacity, 0.0, out);
  for (const OverlayHand& hand : hands)
    for (int j = 0; j < 21; ++j) {
      const auto c = camera.to_camera({hand.joints[3 * j], hand.joints[3 * j + 1], hand.joints[3 * j + 2]});
      if (!(c[2] > 0)) continue;
      const auto uv = camera.project_camera(c);
      cv::circle(out, cv::Point(static_cast<int>(uv[0]), static_cast<int>(uv[1])), 3, cv::Scalar(255, 255, 255),
                 cv::FILLED, cv::LINE_AA);
    }
  if (faces.empty()) return out;
  const cv::Rect crop = cv::Rect(cv::Point(x0 - margin_px, y0 - margin_px), cv::Point(x1 + margin_px, y1 + margin_px)) &
                        cv::Rect(0, 0, out.cols, out.rows);
  return crop.area() > 0 ? out(crop).clone() : out;
}

}  // namespace handscs
