// Atomic file writes: write to "<path>.tmp.<pid>", fsync, rename over the target, fsync the folder.
// A crash at any point leaves either the old file or the new one, never a torn file.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

namespace handscs {

// Writes `bytes` to `path` atomically. Throws Error naming the path on failure.
void write_file_atomic(const std::string& path, const std::string& bytes);

// Throws Error naming the path when it exists but is not a regular file (symlinks followed): a
// folder, a named pipe (opening one blocks until something writes to it), a device such as
// /dev/zero (whose reads never end) or a socket. A missing path passes: opening it reports that.
void refuse_irregular_file(const std::string& path);

// A file opened for reading and checked on its open descriptor, so the check and the read concern
// one file: a path swapped for a named pipe after a check by name cannot block the read. Opening
// does not wait on a named pipe (O_NONBLOCK). Throws Error naming the path: "is a folder, not a
// <kind>", "is not a regular file (...)" as refuse_irregular_file, or "cannot open file".
class ReadableFile {
 public:
  explicit ReadableFile(const std::string& path, const std::string& kind = "file");
  ~ReadableFile();
  ReadableFile(const ReadableFile&) = delete;
  ReadableFile& operator=(const ReadableFile&) = delete;
  // The size the file system reports (0 where it reports none, as for /proc files).
  std::uintmax_t size() const { return size_; }
  // Reads up to n bytes into buffer; returns how many, 0 at the end. Throws Error on a failed read.
  size_t read_some(char* buffer, size_t n);
  // Appends the rest of the file to `bytes` in 64 KiB chunks; false, having stopped, as soon as
  // `bytes` holds more than max_bytes (a file far larger than its format allows, or one still
  // growing, never fills the memory).
  bool append_rest(std::string& bytes, std::uintmax_t max_bytes);

 private:
  std::string path_;
  int fd_ = -1;
  std::uintmax_t size_ = 0;
};

// The bound for files this project writes itself (metrics logs, caches, summaries): they hold text
// or tables of a capture's frames, far below 16 GB even for InterHand2.6M's 2.6 million frames.
constexpr std::uintmax_t kOwnFileMaxBytes = std::uintmax_t{16} << 30;

// Reads a whole regular file of at most `max_bytes` (checked before anything is allocated); throws
// Error naming the path when it is not a regular file, is larger, or cannot be read. A file a user
// gives passes the bound its format allows.
std::string read_file(const std::string& path, std::uintmax_t max_bytes = kOwnFileMaxBytes);

// Creates `dir` (and parents) if needed; throws Error naming it on failure.
void ensure_directory(const std::string& dir);

}  // namespace handscs
