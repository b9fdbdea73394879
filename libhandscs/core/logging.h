// Logging set-up (spdlog): one call at the start of every executable.
#pragma once

#include <string>

namespace handscs {

// level: trace, debug, info, warn, error, off. Throws Error on an unknown name.
void set_log_level(const std::string& level);

}  // namespace handscs
