#include "data/capture_layout.h"

#include <filesystem>

#include "core/error.h"
#include "data/neus_cameras.h"

namespace handscs {

namespace fs = std::filesystem;

namespace {

// The root must be a folder; a link loop or an unreadable parent says why, a missing folder is just
// not a folder.
void require_capture_root(const std::string& root, const std::string& root_key) {
  require(!root.empty(), root_key + ": empty (set it to the dataset folder)");
  std::error_code ec;
  if (!fs::is_directory(root, ec))
    throw Error(root + ": capture root is not a folder" +
                (ec && ec != std::errc::no_such_file_or_directory ? " (" + ec.message() + ")" : ""));
}

}  // namespace

CaptureConfig::Layout detect_capture_layout(const std::string& root, CaptureConfig::Layout setting,
                                            const std::string& root_key) {
  using Layout = CaptureConfig::Layout;
  require_capture_root(root, root_key);
  if (setting != Layout::automatic) return setting;
  const fs::path base(root);
  std::error_code ec;
  // A layout's file that is there but not a file (a named pipe, a device, a folder) is named, not
  // passed over for another layout.
  for (const char* name : {kEasyMocapIntrinsicsFile, kHandscsCaptureFile}) {
    const fs::path path = base / name;
    if (fs::exists(fs::symlink_status(path, ec)) && !fs::is_regular_file(path, ec))
      throw Error(path.string() + ": is not a regular file (a named pipe, a device, a folder or a "
                                  "broken link); give a file");
  }
  if (fs::is_regular_file(base / kEasyMocapIntrinsicsFile, ec)) return Layout::easymocap;
  if (fs::is_regular_file(base / kHandscsCaptureFile, ec)) return Layout::handscs;
  if (!find_neus_camera_archive(root).empty()) return Layout::neus;
  return Layout::interhand;
}

CaptureLayout resolve_capture_layout(const std::string& root, const std::string& split,
                                     const std::string& root_key) {
  require_capture_root(root, root_key);
  std::error_code ec;
  // The 5 fps release unpacks its images into InterHand2.6M_5fps_batch1/; annotations are
  // downloaded separately and may sit beside it or inside it.
  const fs::path base(root);
  const fs::path batch = base / "InterHand2.6M_5fps_batch1";
  CaptureLayout layout;
  for (const fs::path& candidate : {base / "images" / split, batch / "images" / split}) {
    if (fs::is_directory(candidate, ec)) {
      layout.images_dir = candidate.string();
      break;
    }
  }
  require(!layout.images_dir.empty(), root + ": no images/" + split +
                                          "/ folder (nor InterHand2.6M_5fps_batch1/images/" +
                                          split + "/)");
  fs::path annotations;
  for (const fs::path& candidate : {base / "annotations" / split, batch / "annotations" / split}) {
    if (fs::is_directory(candidate, ec)) {
      annotations = candidate;
      break;
    }
  }
  require(!annotations.empty(), root + ": no annotations/" + split + "/ folder");
  const std::string prefix = "InterHand2.6M_" + split + "_";
  layout.data_json = (annotations / (prefix + "data.json")).string();
  layout.camera_json = (annotations / (prefix + "camera.json")).string();
  layout.joint_3d_json = (annotations / (prefix + "joint_3d.json")).string();
  layout.mano_json = (annotations / (prefix + "MANO_NeuralAnnot.json")).string();
  return layout;
}

}  // namespace handscs
