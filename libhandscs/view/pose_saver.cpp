#include "view/pose_saver.h"

#include <cstdio>
#include <filesystem>

#include "core/atomic_file.h"
#include "core/error.h"

namespace handscs {

size_t append_pose(const std::string& path, PoseFrame frame) {
  std::vector<PoseFrame> frames;
  if (std::filesystem::exists(path)) {
    const json root = parse_json_file(path);
    require(root.is_object() && root.contains("poses"),
            path + ": not a POSES list ({\"poses\": [...]}): not overwritten; choose another --save-poses file");
    frames = read_pose_source(path);
  }
  if (frame.name.empty()) {
    char name[32];
    std::snprintf(name, sizeof(name), "view_%04zu", frames.size());
    frame.name = name;
  }
  frame.camera.reset();  // a POSES list holds no cameras
  frames.push_back(frame);
  json list = json::array();
  for (const auto& f : frames) list.push_back(pose_frame_to_json(f));
  write_file_atomic(path, json{{"poses", list}}.dump(1) + "\n");
  return frames.size();
}

}  // namespace handscs
