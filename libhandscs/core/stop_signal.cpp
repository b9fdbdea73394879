#include "core/stop_signal.h"

#include <atomic>

namespace handscs {

namespace {
std::atomic<bool> g_stop_requested{false};
extern "C" void request_stop(int) { g_stop_requested = true; }
}  // namespace

StopSignal::StopSignal() {
  g_stop_requested = false;
  previous_int_ = std::signal(SIGINT, request_stop);
  previous_term_ = std::signal(SIGTERM, request_stop);
}

StopSignal::~StopSignal() {
  std::signal(SIGINT, previous_int_);
  std::signal(SIGTERM, previous_term_);
}

bool StopSignal::requested() { return g_stop_requested.load(); }

}  // namespace handscs
