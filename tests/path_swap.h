// A path swapped, over and over, between a regular file and a named pipe with no writer while a
// reader reads it: a check by name followed by an open by name sooner or later opens the pipe and
// waits forever for a writer. Shared by the tests of read_file and of the image decoders.
#pragma once

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <filesystem>
#include <functional>
#include <string>
#include <thread>

#include "test_support.h"

namespace handscs_test {

// What one read of the swapped path gave.
enum class SwapRead { file, refused, wrong };

// What a read that threw `message` on `path` was: the refusal of the named pipe, or wrong.
inline SwapRead refusal_or_wrong(const std::string& message, const std::string& path) {
  return message == path + ": is not a regular file (a named pipe, a device or a socket); give a file"
             ? SwapRead::refused
             : SwapRead::wrong;
}

// In a child process, a second thread keeps replacing `path` (rename, atomic) by a hard link to
// `file` or by a named pipe, while `read` runs until it has returned `reads` times. The child's
// exit code: 0 when no read was wrong and both the file and a refusal were seen, 1 a wrong read,
// 3 a failed swap, 4 one kind only; -1 when it did not end within `seconds` (a read blocked) and
// was killed. `path` must not exist; its folder is `file`'s.
inline int swapped_path_reads(const std::string& path, const std::string& file,
                              const std::function<SwapRead()>& read, int reads,
                              double seconds = 120) {
  const std::filesystem::path dir = std::filesystem::path(file).parent_path();
  if (::link(file.c_str(), path.c_str()) != 0) return 3;
  const pid_t child = fork();
  if (child < 0) return 3;
  if (child == 0) {
    std::atomic<bool> stop{false};
    std::thread swapper([&] {
      for (long k = 0; !stop; ++k) {
        const std::string next = (dir / ("next" + std::to_string(k))).string();
        const bool ok = k % 2 ? ::mkfifo(next.c_str(), 0600) == 0 : ::link(file.c_str(), next.c_str()) == 0;
        if (!ok || ::rename(next.c_str(), path.c_str()) != 0) _exit(3);
      }
    });
    int refused = 0, whole = 0;
    while (whole + refused < reads) {
      switch (read()) {
        case SwapRead::file: ++whole; break;
        case SwapRead::refused: ++refused; break;
        case SwapRead::wrong: _exit(1);
      }
    }
    stop = true;
    swapper.join();
    _exit(whole > 0 && refused > 0 ? 0 : 4);
  }
  int status = 0;
  if (!wait_until([&] { return waitpid(child, &status, WNOHANG) == child; }, seconds)) {
    ::kill(child, SIGKILL);
    waitpid(child, &status, 0);
    return -1;
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace handscs_test
