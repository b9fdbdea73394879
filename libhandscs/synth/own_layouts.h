// A synthetic capture's files in the project's own layout and in EasyMocap's
// (docs/CAPTURE_FORMAT.md): images/<camera>/<frame>.jpg, regions/<camera>/<frame>.png, and
// capture.json (cameras and frames) or intri.yml + extri.yml with capture.json (frames only). The
// EasyMocap capture's lens has a known distortion (kSynthLensDistortion): its images are the
// pinhole renders distorted with it, so the reader's undistortion recovers them.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "data/lens_distortion.h"
#include "synth/capture.h"

namespace handscs {

// Barrel distortion with a tangential part, as calibrations of machine-vision lenses report: at
// the synthetic focal length (1265 px at 334x512) it moves the image corners by about 4 pixels
// and the hand, near the centre, by a fraction of a pixel.
constexpr LensDistortion kSynthLensDistortion{{-0.25, 0.08, 1e-3, -8e-4, 0.0}};

// The lens of `layout`'s capture: kSynthLensDistortion for easymocap, none otherwise.
LensDistortion synth_lens_distortion(CaptureConfig::Layout layout);

// "<camera>/<frame, six digits>.jpg": the image's path under images/ (a region mask's under
// regions/ with .png).
std::string own_layout_image_name(const SynthFrame& frame, const SynthCamera& camera);

// The camera as the capture's files state it: mirrored for a left-hand capture (synth/mirror.h).
Camera written_camera(const SynthScene& scene, const SynthCamera& camera);

// A hand as the capture's files state it (with the fit error the generator draws): MANO pose
// relative to hands_mean, shape, trans (m) and the 21 MANO-order world joints (m).
struct WrittenHand {
  std::array<double, 48> pose{};
  std::array<double, 10> shape{};
  std::array<double, 3> trans{};
  std::array<double, 63> joints{};
};

// Frame k's hands indexed by Handedness: the one hand (mirrored in a left-hand capture, see
// synth/mirror.h), or both with hand both.
std::array<std::optional<WrittenHand>, 2> written_hands(const SynthScene& scene, size_t k);

// "interacting" (InterHand2.6M's word) for two hands, else the hand's name.
std::string written_hand_type(const SynthScene& scene);

// Writes capture.json (and for easymocap intri.yml, extri.yml) under root; returns the bytes.
int64_t write_own_layout_annotations(const SynthScene& scene, const std::string& root);

}  // namespace handscs
