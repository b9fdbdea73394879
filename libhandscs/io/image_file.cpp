#include "io/image_file.h"

#include <new>

#include "core/error.h"
#include "core/image_header.h"

namespace handscs {

cv::Mat decode_image_bytes(const std::string& bytes, int flags, const std::string& path,
                           const std::string& what) {
  // read_image_bytes bounds a file at 300 MB, so its size fits the int OpenCV's buffer is indexed by.
  const cv::Mat encoded(1, static_cast<int>(bytes.size()), CV_8UC1, const_cast<char*>(bytes.data()));
  try {
    return cv::imdecode(encoded, flags);
  } catch (const cv::Exception& e) {
    // Memory running out is no fault of the file: named as such by the callers that watch for it
    // (train/out_of_memory.h), not taken for a damaged image and skipped.
    if (e.code == cv::Error::StsNoMem) throw std::bad_alloc();
    throw Error(path + ": cannot decode " + what + " (" + e.what() + ")");
  }
}

cv::Mat decode_image_file(const std::string& path, int flags, const std::string& what) {
  return decode_image_bytes(read_image_bytes(path), flags, path, what);
}

}  // namespace handscs
