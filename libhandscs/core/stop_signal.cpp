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
  // Under nohup the process is meant to outlive its terminal: its ignored SIGHUP is left so.
  previous_hup_ = std::signal(SIGHUP, request_stop);
  if (previous_hup_ == SIG_IGN) std::signal(SIGHUP, SIG_IGN);
}

StopSignal::~StopSignal() {
  std::signal(SIGINT, previous_int_);
  std::signal(SIGTERM, previous_term_);
  std::signal(SIGHUP, previous_hup_);
}

bool StopSignal::requested() { return g_stop_requested.load(); }

}  // namespace handscs
