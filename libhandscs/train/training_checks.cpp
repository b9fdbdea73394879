#include "train/training_checks.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <utility>

#include <spdlog/spdlog.h>

#include "core/error.h"
#include "core/text.h"
#include "metrics/lpips.h"
#include "metrics/ssim.h"
#include "train/losses.h"

namespace handscs {

namespace {

// Empty masks after the first steps are logged with their path up to this many times.
constexpr int64_t kEmptyMaskLines = 5;

// The smallest scale that brings `side` pixels to at least min_side (rounded up to 3 decimals).
std::string smallest_scale(int side, int64_t min_side) {
  return number_text(std::ceil(1000.0 * double(min_side) / side) / 1000.0);
}

}  // namespace

int64_t min_loss_image_side(const LossWeights& weights, const Lpips* lpips) {
  int64_t side = 1;
  if (weights.ssim > 0) side = std::max(side, kSsimWindow);
  if (lpips && weights.lpips > 0) {
    // The smallest crop side that is still min_image_side() after train.loss.lpips_scale.
    int64_t lpips_side = lpips->min_image_side();
    while (scaled_side(lpips_side, weights.lpips_scale) < lpips->min_image_side()) ++lpips_side;
    side = std::max(side, lpips_side);
  }
  return side;
}

void check_training_image_sizes(const std::vector<FrameInfo>& train, double scale, int64_t min_side) {
  std::map<std::pair<int, int>, const FrameInfo*> sizes;  // one frame per image size
  for (const FrameInfo& f : train) sizes.emplace(std::make_pair(f.camera.width, f.camera.height), &f);
  for (const auto& [size, frame] : sizes) {
    const int w = static_cast<int>(scaled_side(size.first, scale));
    const int h = static_cast<int>(scaled_side(size.second, scale));
    if (w >= min_side && h >= min_side) continue;
    throw Error("train.resolution_scale: " + number_text(scale) + " scales the " +
                std::to_string(size.first) + "x" + std::to_string(size.second) + " images (" +
                frame->image_path + ") to " + std::to_string(w) + "x" + std::to_string(h) +
                ", smaller than the " + std::to_string(min_side) + "x" + std::to_string(min_side) +
                " the image losses need (SSIM window, LPIPS backbone after train.loss.lpips_scale); use at least " +
                smallest_scale(std::min(size.first, size.second), min_side) +
                " (crops around the hand need more), or set train.loss.ssim and train.loss.lpips to 0");
  }
}

std::string scaled_crop_problem(const FrameInfo& frame, int width, int height, double scale,
                                int64_t min_side) {
  if (width >= min_side && height >= min_side) return "";
  const int crop_side = static_cast<int>(std::min(width, height) / scale + 0.5);
  return "train.resolution_scale: " + number_text(scale) + " scales the crop around the hand in " +
         frame.image_path + " to " + std::to_string(width) + "x" + std::to_string(height) +
         ", smaller than the " + std::to_string(min_side) + "x" + std::to_string(min_side) +
         " the image losses need (SSIM window, LPIPS backbone after train.loss.lpips_scale); use at least " +
         smallest_scale(std::max(1, crop_side), min_side) +
         ", or set train.loss.ssim and train.loss.lpips to 0";
}

std::string batch_size_warning(int64_t batch_size, int64_t processes, int64_t training_views) {
  const int64_t per_step = batch_size * processes;
  if (per_step <= training_views) return "";
  char text[320];
  std::snprintf(text, sizeof(text),
                "train.batch_size: %lld views a step%s but the capture has %lld training views: "
                "each view is rendered ~%.1f times a step, and a step costs %lld renders",
                static_cast<long long>(per_step),
                processes > 1 ? (" (" + std::to_string(processes) + " processes)").c_str() : "",
                static_cast<long long>(training_views),
                static_cast<double>(per_step) / static_cast<double>(training_views),
                static_cast<long long>(per_step));
  return text;
}

void EmptyMaskWatch::record(const FrameInfo& frame, bool empty) {
  ++seen_;
  if (!empty) {
    any_hand_ = true;
    return;
  }
  ++empty_;
  // A supplied mask file is what is empty; a rasterised one says the posed hand missed the view.
  const bool supplied = !frame.mask_path.empty();
  if (!any_hand_ && seen_ >= steps_)
    throw Error("the hand masks of the first " + std::to_string(seen_) +
                " training images are all empty (the last: " +
                (supplied ? "mask " + frame.mask_path + " of " : std::string()) + frame.image_path +
                "): nothing to learn from. " +
                (supplied ? std::string("The supplied masks hold no hand pixel: check the mask files "
                                        "(non-zero = hand)")
                          : std::string("The posed MANO hand covers no pixel of these views: check "
                                        "the MANO annotation (shape, trans), data.hand, data.rig and "
                                        "the cameras")));
  if (any_hand_ && empty_ <= kEmptyMaskLines) {
    if (supplied)
      spdlog::warn("{}: the supplied mask of {} holds no hand pixel; the step learns background only",
                   frame.mask_path, frame.image_path);
    else
      spdlog::warn("{}: the hand mask is empty (the posed hand covers no pixel); the step learns "
                   "background only", frame.image_path);
  }
}

std::string missing_hand_warning(const std::vector<FrameInfo>& train) {
  for (const Handedness side : {Handedness::right, Handedness::left}) {
    const bool any = std::any_of(train.begin(), train.end(),
                                 [&](const FrameInfo& frame) { return frame.hand(side) != nullptr; });
    if (any) continue;
    const Handedness other = other_hand(side);
    return "data.hand both: none of the " + std::to_string(train.size()) + " training frames has the " +
           hand_name(side) + " hand (its annotations are absent or null), so its avatar would keep its " +
           "initial state; data.hand=" + hand_name(other) + " trains the " + hand_name(other) +
           " hand alone";
  }
  return "";
}

}  // namespace handscs
