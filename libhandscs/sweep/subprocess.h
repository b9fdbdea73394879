// Runs a child program and measures it: exit status, wall time and peak resident memory (from the
// kernel's rusage of that child alone). The sweep runs handscs-train and handscs-eval this way, so
// each point's memory is its own and a crash in one point does not end the sweep.
#pragma once

#include <string>
#include <vector>

namespace handscs {

struct ProcessResult {
  int exit_code = -1;     // the child's exit status; 128 + signal number if a signal ended it
  double wall_seconds = 0;
  double peak_rss_mb = 0;  // maximum resident set size of the child (MiB)
};

// Runs argv[0] (searched on PATH when it has no '/') with argv; stdout and stderr go to log_path
// (created or truncated). Throws Error when the program cannot be started at all.
ProcessResult run_process(const std::vector<std::string>& argv, const std::string& log_path);

}  // namespace handscs
