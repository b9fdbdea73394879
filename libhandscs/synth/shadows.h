// Soft cast shadows of a distant area light on a posed mesh: the visibility of vertex i is the
// fraction of S rays from x_i (lifted off the surface) towards directions inside a cone of the
// light's angular radius that hit no triangle (Moller-Trumbore), the triangles around x_i excluded.
// Vertices facing away from the light get visibility 1: Lambert's cosine already darkens them.
#pragma once

#include <cstdint>
#include <vector>

#include "synth/math.h"

namespace handscs {

// vertices/normals [V * 3] world metres; faces [F * 3]; light: unit direction towards the light.
std::vector<float> light_visibility(const std::vector<float>& vertices,
                                    const std::vector<float>& normals,
                                    const std::vector<int64_t>& faces, const synth::Vec3& light,
                                    double radius_rad, int samples);

}  // namespace handscs
