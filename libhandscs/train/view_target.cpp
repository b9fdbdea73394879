#include "train/view_target.h"

#include <random>

#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "data/camera_transforms.h"
#include "train/losses.h"
#include "train/training_checks.h"

namespace handscs {

std::array<float, 3> training_background(TrainConfig::Background kind, int64_t seed,
                                         int64_t view_index) {
  if (kind == TrainConfig::Background::white) return {1, 1, 1};
  if (kind == TrainConfig::Background::black) return {0, 0, 0};
  std::mt19937_64 rng(static_cast<uint64_t>(seed) * 7919ull + view_index);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  return {u(rng), u(rng), u(rng)};
}

ViewTarget make_view_target(const FrameSample& sample, const FrameInfo& frame, double scale,
                            int64_t min_side, const std::array<float, 3>& background) {
  ViewTarget view;
  view.camera = sample.roi_camera();
  torch::Tensor image = sample.image.to(torch::kFloat32).div_(255.0);  // [h, w, 3]
  view.mask = sample.mask.to(torch::kFloat32);                        // [h, w]
  if (scale != 1.0) {
    const int w = static_cast<int>(scaled_side(view.camera.width, scale));
    const int h = static_cast<int>(scaled_side(view.camera.height, scale));
    cv::Mat img(image.size(0), image.size(1), CV_32FC3, image.data_ptr<float>());
    cv::Mat msk(view.mask.size(0), view.mask.size(1), CV_32FC1, view.mask.data_ptr<float>());
    cv::Mat img_small, msk_small;
    cv::resize(img, img_small, cv::Size(w, h), 0, 0, cv::INTER_AREA);
    cv::resize(msk, msk_small, cv::Size(w, h), 0, 0, cv::INTER_AREA);
    image = torch::from_blob(img_small.data, {h, w, 3}, torch::kFloat32).clone();
    view.mask = torch::from_blob(msk_small.data, {h, w}, torch::kFloat32).clone();
    view.camera = resample_camera(view.camera, double(w) / view.camera.width, w, h);
  }
  const std::string too_small = scaled_crop_problem(frame, static_cast<int>(image.size(1)),
                                                    static_cast<int>(image.size(0)), scale,
                                                    min_side);
  if (!too_small.empty()) throw Error(too_small);
  view.background = background;
  const auto bg = torch::tensor({background[0], background[1], background[2]});
  const auto mask3 = view.mask.unsqueeze(2);
  view.target = image * mask3 + bg * (1 - mask3);
  return view;
}

}  // namespace handscs
