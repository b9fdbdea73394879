#include "sweep/subprocess.h"

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

#include "core/error.h"

namespace handscs {

ProcessResult run_process(const std::vector<std::string>& argv, const std::string& log_path) {
  require(!argv.empty(), "run_process: empty command");
  const int log = ::open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (log < 0) throw Error(log_path + ": cannot create log file (" + std::strerror(errno) + ")");
  // An exec failure is reported through a close-on-exec pipe: EOF means the exec succeeded.
  int status_pipe[2];
  if (::pipe2(status_pipe, O_CLOEXEC) != 0) {
    ::close(log);
    throw Error("run_process: pipe failed (" + std::string(std::strerror(errno)) + ")");
  }
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);

  const auto start = std::chrono::steady_clock::now();
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(log);
    ::close(status_pipe[0]);
    ::close(status_pipe[1]);
    throw Error("run_process: fork failed (" + std::string(std::strerror(errno)) + ")");
  }
  if (pid == 0) {
    ::dup2(log, STDOUT_FILENO);
    ::dup2(log, STDERR_FILENO);
    ::execvp(args[0], args.data());
    const int error = errno;
    (void)!::write(status_pipe[1], &error, sizeof(error));
    ::_exit(127);
  }
  ::close(log);
  ::close(status_pipe[1]);
  int exec_error = 0;
  const ssize_t got = ::read(status_pipe[0], &exec_error, sizeof(exec_error));
  ::close(status_pipe[0]);

  int status = 0;
  struct rusage usage {};
  while (::wait4(pid, &status, 0, &usage) < 0 && errno == EINTR) {
  }
  if (got == static_cast<ssize_t>(sizeof(exec_error)))
    throw Error(argv[0] + ": cannot run (" + std::strerror(exec_error) + ")");

  ProcessResult result;
  result.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  result.peak_rss_mb = static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return result;
}

}  // namespace handscs
