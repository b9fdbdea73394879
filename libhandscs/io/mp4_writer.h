// MP4 videos the tools write (handscs-render --video): frames go to a temporary file beside the
// target, renamed onto it only when the last frame is in, so a failed render leaves no torn video.
// Where the target cannot be written (no such folder, read-only file system, a folder in its place)
// the error names the path and the system's reason before any frame is rendered, instead of
// OpenCV's backend assertions.
#pragma once

#include <memory>
#include <string>

#include <opencv2/core/mat.hpp>

namespace cv {
class VideoWriter;
}

namespace handscs {

class Mp4Writer {
 public:
  // Checks that `path` can be written (by creating and removing its temporary file); throws Error
  // naming the path and the reason when not. fps in (0, 240] (the callers' command-line range).
  Mp4Writer(const std::string& path, double fps);
  ~Mp4Writer();  // an unfinished video's temporary file is removed
  Mp4Writer(const Mp4Writer&) = delete;
  Mp4Writer& operator=(const Mp4Writer&) = delete;

  // Appends one 8-bit BGR frame; every frame must have the first one's size.
  void write(const cv::Mat& bgr);
  // Closes the video and renames it onto the target. A video with no frame throws Error.
  void finish();
  // Drops the video: its temporary file is removed and the target left as it was.
  void abandon();

  const std::string& path() const { return path_; }

 private:
  std::string path_, temp_;
  double fps_;
  cv::Size size_;
  std::unique_ptr<cv::VideoWriter> writer_;
};

}  // namespace handscs
