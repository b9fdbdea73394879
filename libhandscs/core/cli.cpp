#include "core/cli.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstring>

#include <c10/util/Exception.h>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "core/allocator.h"
#include "core/logging.h"
#include "core/threads.h"

namespace handscs {

void add_common_options(CLI::App& app, CommonOptions& options, bool with_overrides) {
  app.add_option("--threads", options.threads,
                 "worker threads for LibTorch and OpenMP (0 = all cores)")
      ->check(CLI::Range(0, 1024));
  app.add_option("--log-level", options.log_level, "trace, debug, info, warn, error or off");
  if (with_overrides)
    app.add_option("--set", options.overrides,
                   "override a config key, e.g. --set train.iterations=2000 (repeatable)")
        ->take_all();
}

std::string error_text(const std::exception& e) {
  const auto* torch_error = dynamic_cast<const c10::Error*>(&e);
  const char* keep_trace = std::getenv("HANDSCS_BACKTRACE");
  if (torch_error && !(keep_trace && std::strcmp(keep_trace, "1") == 0))
    return torch_error->what_without_backtrace();
  return e.what();
}

void start_up(const CommonOptions& options, const std::string& program) {
  keep_freed_memory_for_reuse();
  set_log_level(options.log_level);
  const int threads = set_threads(options.threads);
  spdlog::info("{}: {} thread{}, BLAS {}", program, threads, threads == 1 ? "" : "s",
               blas_in_use());
}

std::string shell_quote(const std::string& text) {
  const bool plain = !text.empty() && std::all_of(text.begin(), text.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || std::strchr("/._-+=:,", c) != nullptr;
  });
  if (plain) return text;
  std::string out = "'";
  for (char c : text) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

}  // namespace handscs
