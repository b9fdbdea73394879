// Images and masks decoded from the bytes of one checked read (core/image_header.h
// read_image_bytes), never by cv::imread's own open of the path: a path swapped for a named pipe
// after a check by name could block that open forever, and a header stating 30000 x 30000 pixels
// would allocate gigabytes before any check. cv::imdecode applies a JPEG's EXIF orientation as
// cv::imread does (OpenCV 4.6; tests/io/test_image_file.cpp holds it to imread).
#pragma once

#include <opencv2/core/mat.hpp>
#include <opencv2/imgcodecs.hpp>  // the cv::IMREAD_* flags callers pass
#include <string>

namespace handscs {

// `bytes` (read from `path`) decoded with cv::imread's `flags`. Returns an empty Mat, as cv::imread
// does, when OpenCV cannot decode them; throws Error "<path>: cannot decode <what> (...)" when
// OpenCV throws, std::bad_alloc when its allocation failed. `what` names the file's role ("image",
// "mask", ...).
cv::Mat decode_image_bytes(const std::string& bytes, int flags, const std::string& path,
                           const std::string& what = "image");

// The file at `path` read (read_image_bytes: its errors name the path) and decoded with `flags`.
cv::Mat decode_image_file(const std::string& path, int flags, const std::string& what = "image");

}  // namespace handscs
