#include "io/mp4_writer.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include <opencv2/videoio.hpp>
#include <opencv2/videoio/registry.hpp>

#include "core/error.h"

namespace handscs {

namespace {

// FFmpeg writes MP4 wherever the file can be created; asked through CAP_ANY, OpenCV tries the next
// backend (GStreamer) after a failure and prints that backend's internal assertion, which names
// neither the file nor the cause. Falls back to any backend where OpenCV was built without FFmpeg.
int mp4_backend() {
  return cv::videoio_registry::hasBackend(cv::CAP_FFMPEG) ? cv::CAP_FFMPEG : cv::CAP_ANY;
}

}  // namespace

Mp4Writer::Mp4Writer(const std::string& path, double fps)
    : path_(path), temp_(path + ".tmp.mp4"), fps_(fps) {
  require(fps > 0 && fps <= 240, path + ": video frame rate " + std::to_string(fps) +
                                     " outside (0, 240]");
  std::error_code ec;
  require(!std::filesystem::is_directory(path, ec), path + ": is a folder, not a video file");
  const auto parent = std::filesystem::path(path).parent_path();
  if (!parent.empty())
    require(std::filesystem::is_directory(parent, ec),
            path + ": cannot write the video: " + parent.string() + " is not a folder");
  // Created (and removed) here so that the system's own reason reaches the user: a read-only file
  // system, missing permission, a full disk's inode table.
  const int fd = ::open(temp_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd < 0)
    throw Error(path + ": cannot write the video (" + std::strerror(errno) + ")");
  ::close(fd);
  std::filesystem::remove(temp_, ec);
  writer_ = std::make_unique<cv::VideoWriter>();
}

Mp4Writer::~Mp4Writer() { abandon(); }

void Mp4Writer::write(const cv::Mat& bgr) {
  require(bgr.type() == CV_8UC3, path_ + ": video frames are 8-bit BGR images");
  if (!writer_->isOpened()) {
    size_ = bgr.size();
    writer_->open(temp_, mp4_backend(), cv::VideoWriter::fourcc('m', 'p', '4', 'v'), fps_, size_);
    if (!writer_->isOpened())
      throw Error(path_ + ": OpenCV cannot encode MP4 video here (its FFmpeg backend refused " +
                  std::to_string(size_.width) + "x" + std::to_string(size_.height) + " at " +
                  std::to_string(fps_) + " fps)");
  }
  if (bgr.size() != size_)
    throw Error(path_ + ": all frames of a video need one image size (" +
                std::to_string(size_.width) + "x" + std::to_string(size_.height) + " first, then " +
                std::to_string(bgr.cols) + "x" + std::to_string(bgr.rows) + ")");
  writer_->write(bgr);
}

void Mp4Writer::finish() {
  require(writer_ && writer_->isOpened(), path_ + ": a video needs at least one frame");
  writer_->release();
  std::error_code ec;
  std::filesystem::rename(temp_, path_, ec);
  if (ec) throw Error(path_ + ": cannot move the finished video into place (" + ec.message() + ")");
  writer_.reset();
}

void Mp4Writer::abandon() {
  if (!writer_) return;
  if (writer_->isOpened()) writer_->release();
  std::error_code ec;
  std::filesystem::remove(temp_, ec);
  writer_.reset();
}

}  // namespace handscs
