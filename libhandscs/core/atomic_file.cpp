#include "core/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "core/error.h"

namespace handscs {

namespace {
void fsync_path(const std::string& path, int flags) {
  const int fd = ::open(path.c_str(), flags);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
}
}  // namespace

void write_file_atomic(const std::string& path, const std::string& bytes) {
  const std::string temp = path + ".tmp." + std::to_string(::getpid());
  const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd < 0) throw Error(path + ": cannot write (" + std::strerror(errno) + ")");
  size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + written, bytes.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      const std::string reason = std::strerror(errno);
      ::close(fd);
      ::unlink(temp.c_str());
      throw Error(path + ": write failed (" + reason + ")");
    }
    written += static_cast<size_t>(n);
  }
  if (::fsync(fd) != 0 || ::close(fd) != 0) {
    ::unlink(temp.c_str());
    throw Error(path + ": write failed (" + std::strerror(errno) + ")");
  }
  if (::rename(temp.c_str(), path.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    ::unlink(temp.c_str());
    throw Error(path + ": cannot replace (" + reason + ")");
  }
  std::string dir = std::filesystem::path(path).parent_path().string();
  fsync_path(dir.empty() ? "." : dir, O_RDONLY | O_DIRECTORY);
}

void refuse_irregular_file(const std::string& path) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status) || std::filesystem::is_regular_file(status)) return;
  if (std::filesystem::is_directory(status)) throw Error(path + ": is a folder, not a file");
  throw Error(path + ": is not a regular file (a named pipe, a device or a socket); give a file");
}

ReadableFile::ReadableFile(const std::string& path, const std::string& kind) : path_(path) {
  // By name first, so a device is never opened; then again on the descriptor below.
  if (std::error_code ec; std::filesystem::is_directory(path, ec))
    throw Error(path + ": is a folder, not a " + kind);
  refuse_irregular_file(path);
  fd_ = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) throw Error(path + ": cannot open file");
  struct stat st {};
  if (::fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode)) {
    const bool folder = S_ISDIR(st.st_mode);
    ::close(fd_);
    throw Error(path + (folder ? ": is a folder, not a " + kind
                               : std::string(": is not a regular file (a named pipe, a device or a "
                                             "socket); give a file")));
  }
  ::fcntl(fd_, F_SETFL, ::fcntl(fd_, F_GETFL) & ~O_NONBLOCK);  // reads of a regular file block
  size_ = static_cast<std::uintmax_t>(st.st_size);
}

ReadableFile::~ReadableFile() { ::close(fd_); }

size_t ReadableFile::read_some(char* buffer, size_t n) {
  while (true) {
    const ssize_t got = ::read(fd_, buffer, n);
    if (got >= 0) return static_cast<size_t>(got);
    if (errno != EINTR) throw Error(path_ + ": read failed (" + std::strerror(errno) + ")");
  }
}

bool ReadableFile::append_rest(std::string& bytes, std::uintmax_t max_bytes) {
  char chunk[1 << 16];
  while (const size_t got = read_some(chunk, sizeof(chunk))) {
    bytes.append(chunk, got);
    if (bytes.size() > max_bytes) return false;
  }
  return true;
}

std::string read_file(const std::string& path, std::uintmax_t max_bytes) {
  ReadableFile file(path);
  const std::uintmax_t size = file.size();
  if (size > max_bytes)
    throw Error(path + ": " + std::to_string(size >> 20) + " MB, more than the " +
                std::to_string(max_bytes >> 20) + " MB such a file can be");
  // The whole size is allocated first, so a file the process cannot hold is named here instead of
  // surfacing as std::bad_alloc from a buffer growing somewhere in the read.
  std::string bytes;
  try {
    bytes.resize(size);
  } catch (const std::bad_alloc&) {
    throw Error(path + ": " + std::to_string(size >> 20) + " MB do not fit in this process's memory");
  }
  size_t filled = 0;
  while (filled < bytes.size()) {
    const size_t got = file.read_some(bytes.data() + filled, bytes.size() - filled);
    if (got == 0) break;  // a file that shrank while read
    filled += got;
  }
  bytes.resize(filled);
  // No size reported (a special file system): read as it comes, within the bound.
  if (size == 0 && !file.append_rest(bytes, max_bytes))
    throw Error(path + ": more than the " + std::to_string(max_bytes >> 20) + " MB such a file can be");
  return bytes;
}

void ensure_directory(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir))
    throw Error(dir + ": cannot create directory (" + ec.message() + ")");
}

}  // namespace handscs
