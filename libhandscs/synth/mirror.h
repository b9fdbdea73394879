// A left-hand synthetic capture as the mirror image of the right-hand one (SynthConfig::hand =
// "left"): the world is reflected through x = 0 (M = diag(-1, 1, 1)), which turns the built-in right
// hand into the built-in left hand (hand/rig_mirror.h), and every camera is reflected with it, so
// each image is the right-hand image flipped left to right. Everything written is mirrored
// consistently: cameras, 3-D joints, MANO parameters and boxes.
#pragma once

#include <array>

#include "data/interhand_annotations.h"

namespace handscs {

// The camera that sees the mirrored world as the flipped image of `raw`'s view of the original:
// campos' = M campos, camrot' = M R M (a rotation again), principal point x' = width - x (pixel i
// is centred at i + 0.5, so column i becomes column width - 1 - i).
InterHandCamera mirror_interhand_camera(const InterHandCamera& raw, int width);

// MANO pose (48 axis-angle values, global orientation first) of the mirrored hand: the axis-angle
// of M R M is (a, -b, -c). Holds for poses relative to hands_mean too, since the mirrored rig's
// hands_mean is mirrored the same way.
std::array<double, 48> mirror_mano_pose(const std::array<double, 48>& pose);

// A point or translation: x -> -x. MANO's trans mirrors like a point (LBS is linear in it and the
// mirrored rig's root joint is the mirrored root joint).
std::array<double, 3> mirror_point(const std::array<double, 3>& point);

// An image box [x, y, w, h] after flipping an image `width` pixels wide left to right.
std::array<double, 4> mirror_box(const std::array<double, 4>& box, int width);

}  // namespace handscs
