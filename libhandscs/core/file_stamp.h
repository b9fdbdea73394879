// A file's size and modification time: what the caches take to tell one version of a file from
// another without reading it (the image-check cache per image, the annotation cache with a hash of
// the file's edges beside it, the mask and undistortion caches' folder keys). A rewrite that keeps
// both goes unnoticed (docs/NOTES.md#data-and-files).
#pragma once

#include <sys/stat.h>

#include <cstdint>
#include <string>

namespace handscs {

struct FileStamp {
  uint64_t size = 0;
  int64_t mtime_ns = 0;  // nanoseconds since the Unix epoch
  bool operator==(const FileStamp& o) const { return size == o.size && mtime_ns == o.mtime_ns; }
  bool operator!=(const FileStamp& o) const { return !(*this == o); }
};

// The stamp of `path` into `stamp`; false, leaving `stamp` as it was, when the file cannot be
// stat'ed.
inline bool read_file_stamp(const std::string& path, FileStamp& stamp) {
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) return false;
  stamp.size = static_cast<uint64_t>(info.st_size);
  stamp.mtime_ns = static_cast<int64_t>(info.st_mtim.tv_sec) * 1000000000 + info.st_mtim.tv_nsec;
  return true;
}

}  // namespace handscs
