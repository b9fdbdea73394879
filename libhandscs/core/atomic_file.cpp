#include "core/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

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

std::string read_file(const std::string& path, std::uintmax_t max_bytes) {
  refuse_irregular_file(path);
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (!ec && size > max_bytes)
    throw Error(path + ": " + std::to_string(size >> 20) + " MB, more than the " +
                std::to_string(max_bytes >> 20) + " MB such a file can be");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open file");
  if (ec) {  // no size known (a special file system): read as it comes
    std::ostringstream buffer;
    buffer << in.rdbuf();
    if (in.bad()) throw Error(path + ": read failed");
    return buffer.str();
  }
  // The whole size is allocated first, so a file the process cannot hold is named here instead of
  // surfacing as std::bad_alloc from a buffer growing somewhere in the read.
  std::string bytes;
  try {
    bytes.resize(size);
  } catch (const std::bad_alloc&) {
    throw Error(path + ": " + std::to_string(size >> 20) + " MB do not fit in this process's memory");
  }
  in.read(bytes.data(), static_cast<std::streamsize>(size));
  if (in.bad()) throw Error(path + ": read failed");
  bytes.resize(static_cast<size_t>(in.gcount()));  // a file that shrank while read
  return bytes;
}

void ensure_directory(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir))
    throw Error(dir + ": cannot create directory (" + ec.message() + ")");
}

}  // namespace handscs
