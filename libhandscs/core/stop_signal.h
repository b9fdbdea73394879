// Ctrl-C (SIGINT), SIGTERM and SIGHUP (the terminal closed, an ssh session dropped) as a request to
// stop that long loops poll, while a StopSignal lives: training saves a checkpoint and ends,
// synthesis drops its unfinished capture. A SIGHUP ignored when it is installed (nohup) stays
// ignored. The previous handlers come back when it goes, also when the loop ends by an exception.
#pragma once

#include <csignal>

namespace handscs {

class StopSignal {
 public:
  StopSignal();   // installs the handlers and clears any earlier request
  ~StopSignal();  // restores the handlers that were there before
  StopSignal(const StopSignal&) = delete;
  StopSignal& operator=(const StopSignal&) = delete;

  // True once SIGINT, SIGTERM or SIGHUP arrived while a StopSignal was installed.
  static bool requested();

 private:
  using Handler = void (*)(int);
  Handler previous_int_, previous_term_, previous_hup_;
};

}  // namespace handscs
