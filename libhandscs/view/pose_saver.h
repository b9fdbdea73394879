// The viewer's "save pose" button: appends a pose to a POSES file in its list form
// ({"poses": [...]}, infer/pose_source.h), creating the file, so handscs-render reads it as it is.
#pragma once

#include <cstddef>
#include <string>

#include "infer/pose_source.h"

namespace handscs {

// Appends `frame` (named "view_NNNN" by its position when it has no name) and returns the file's
// pose count. An existing file must be a readable POSES list (read_pose_source's checks): any other
// file is an Error naming it and is left as it was. The write is atomic.
size_t append_pose(const std::string& path, PoseFrame frame);

}  // namespace handscs
