#include "core/logging.h"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "core/error.h"

namespace handscs {

void set_log_level(const std::string& level) {
  const auto parsed = spdlog::level::from_str(level);
  if (parsed == spdlog::level::off && level != "off")
    throw Error("--log-level " + level + ": unknown level (trace, debug, info, warn, error, off)");
  spdlog::set_level(parsed);
  spdlog::set_pattern("[%H:%M:%S] [%^%l%$] %v");
}

void log_to_stderr() {
  auto logger = spdlog::stderr_color_mt("stderr");
  logger->set_level(spdlog::default_logger()->level());
  spdlog::set_default_logger(logger);
  spdlog::set_pattern("[%H:%M:%S] [%^%l%$] %v");
}

}  // namespace handscs
