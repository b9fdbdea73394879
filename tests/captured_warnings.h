// The messages logged at warn level or above while a CapturedWarnings lives: a ring buffer added to
// the default logger's sinks, removed again when it goes.
#pragma once

#include <spdlog/sinks/ringbuffer_sink.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

namespace handscs_test {

struct CapturedWarnings {
  // 256 messages: more than any test logs (a short training run warns a few dozen times at most).
  std::shared_ptr<spdlog::sinks::ringbuffer_sink_mt> sink = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(256);
  CapturedWarnings() {
    sink->set_level(spdlog::level::warn);
    spdlog::default_logger()->sinks().push_back(sink);
  }
  ~CapturedWarnings() {
    auto& sinks = spdlog::default_logger()->sinks();
    sinks.erase(std::remove(sinks.begin(), sinks.end(), sink), sinks.end());
  }
  CapturedWarnings(const CapturedWarnings&) = delete;
  CapturedWarnings& operator=(const CapturedWarnings&) = delete;

  // Each message's text, oldest first.
  std::vector<std::string> messages() const {
    std::vector<std::string> out;
    for (const auto& message : sink->last_raw()) out.emplace_back(message.payload.data(), message.payload.size());
    return out;
  }
  // All messages, one per line.
  std::string text() const {
    std::string out;
    for (const auto& message : messages()) out += message + "\n";
    return out;
  }
};

}  // namespace handscs_test
