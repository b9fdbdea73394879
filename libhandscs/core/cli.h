// Options every executable shares (--threads, --log-level, --set) and the start-up they trigger.
#pragma once

#include <exception>
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace handscs {

struct CommonOptions {
  int threads = 0;                    // 0 = all available cores
  std::string log_level = "info";     // spdlog level name
  std::vector<std::string> overrides; // --set key.path=value
};

// Adds --threads and --log-level (and --set when with_overrides) to `app`.
void add_common_options(CLI::App& app, CommonOptions& options, bool with_overrides);

// Applies the allocator settings (core/allocator.h), logging and thread settings, and logs the
// thread count and BLAS library in use.
void start_up(const CommonOptions& options, const std::string& program);

// The message a program prints for an exception that ends it: e.what(), but for LibTorch's
// c10::Error only the message, without the C++ stack trace it carries (users act on the message;
// the trace names internal frames). HANDSCS_BACKTRACE=1 keeps the trace for bug reports.
std::string error_text(const std::exception& e);

// `text` as one POSIX shell word ('...' with embedded quotes escaped), for commands a program
// prints for the user to paste; plain words (letters, digits, /._-+=:,) are left as they are.
std::string shell_quote(const std::string& text);

}  // namespace handscs
