// Logging set-up (spdlog): one call at the start of every executable.
#pragma once

#include <string>

namespace handscs {

// level: trace, debug, info, warn, error, off. Throws Error on an unknown name.
void set_log_level(const std::string& level);

// Sends every log line to stderr (the default is stdout): for programs whose stdout is data, as
// the benchmark executables that print one JSON object.
void log_to_stderr();

}  // namespace handscs
