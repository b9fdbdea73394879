// EasyMocap's (and ZJU-MoCap's) camera files, read with cv::FileStorage: intri.yml holds `names`
// (the camera names), K_<name> (3x3, OpenCV's pixel centres on integers), dist_<name> (1x5 or 1x4:
// k1 k2 p1 p2 [k3]; D_<name> is read when dist_ is absent) and optionally H_<name>, W_<name>
// (image size); extri.yml holds R_<name> (Rodrigues 3x1), optionally Rot_<name> (3x3, which must
// agree) and T_<name> (3x1, metres) with x_cam = R x_world + T.
#pragma once

#include <map>
#include <string>

#include "data/capture_records.h"

namespace handscs {

// Cameras by name, K in core/camera.h's convention (cx, cy plus half a pixel). Width and height
// are 0 when intri.yml has no H_/W_. Throws Error naming the file and key for anything missing,
// misshapen or implausible.
std::map<std::string, RecordCamera> read_easymocap_cameras(const std::string& intri_path,
                                                           const std::string& extri_path);

// Writes `cameras` in the same form (synthetic captures), K shifted back to OpenCV's convention.
void write_easymocap_cameras(const std::map<std::string, RecordCamera>& cameras,
                             const std::string& intri_path, const std::string& extri_path);

}  // namespace handscs
