// Camera rig of a synthetic capture: cameras on a band of a sphere around the hand, looking at it,
// with InterHand-like intrinsics (focal ~1265 px at 334x512, principal point near the centre);
// portrait 334x512 cameras show the fingers up, every k-th camera is rolled to landscape 512x334.
#pragma once

#include <string>
#include <vector>

#include "core/camera.h"
#include "data/interhand_annotations.h"
#include "synth/config.h"
#include "synth/math.h"

namespace handscs {

struct SynthCamera {
  std::string id;       // "400002", "400004", ...
  InterHandCamera raw;  // as written to camera.json (campos in mm)
  Camera camera;        // camera_from_interhand(raw): exactly what the reader reconstructs
  bool landscape = false;
};

// target: point the cameras look at (m); up: world direction shown upwards in portrait images;
// side: a direction orthogonal to `up` fixing the azimuth origin.
std::vector<SynthCamera> make_synth_cameras(const SynthConfig& config, const synth::Vec3& target,
                                            const synth::Vec3& up, const synth::Vec3& side);

}  // namespace handscs
