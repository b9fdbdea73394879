// A one-line terminal progress bar: count/total, rate, ETA and a caller-supplied status text.
// Redraws at most every 100 ms on a terminal; on a pipe or file it prints a line every 10%.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

namespace handscs {

class ProgressBar {
 public:
  // `unit` names what is counted in the rate ("it/s", "MB/s").
  ProgressBar(std::string label, int64_t total, std::string unit = "it");
  ~ProgressBar();
  // Marks `done` items finished and shows `status` (e.g. "loss 0.031 psnr 28.4").
  void update(int64_t done, const std::string& status = "");
  void finish(const std::string& status = "");

 private:
  void draw(bool final);
  std::string label_;
  int64_t total_;
  std::string unit_;
  int64_t done_ = 0;
  int64_t start_done_ = -1;
  std::string status_;
  bool is_tty_;
  bool finished_ = false;
  int last_decile_ = -1;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
};

}  // namespace handscs
