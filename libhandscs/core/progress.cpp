#include "core/progress.h"

#include <unistd.h>

#include <cstdio>

namespace handscs {

namespace {
std::string format_duration(double seconds) {
  if (!(seconds >= 0) || seconds > 1e7) return "--:--";
  const int64_t s = static_cast<int64_t>(seconds + 0.5);
  char buffer[32];
  if (s >= 3600)
    std::snprintf(buffer, sizeof(buffer), "%lld:%02lld:%02lld", (long long)(s / 3600),
                  (long long)(s / 60 % 60), (long long)(s % 60));
  else
    std::snprintf(buffer, sizeof(buffer), "%02lld:%02lld", (long long)(s / 60), (long long)(s % 60));
  return buffer;
}
}  // namespace

ProgressBar::ProgressBar(std::string label, int64_t total, std::string unit)
    : label_(std::move(label)),
      total_(total > 0 ? total : 1),
      unit_(std::move(unit)),
      is_tty_(isatty(fileno(stderr))) {
  start_ = last_draw_ = std::chrono::steady_clock::now();
}

ProgressBar::~ProgressBar() {
  if (!finished_ && done_ > 0 && is_tty_) std::fputc('\n', stderr);
}

void ProgressBar::update(int64_t done, const std::string& status) {
  if (start_done_ < 0) {
    // Rate and ETA count from the first update (a resumed run starts part-way).
    start_done_ = done;
    start_ = std::chrono::steady_clock::now();
  }
  done_ = done;
  status_ = status;
  const auto now = std::chrono::steady_clock::now();
  if (is_tty_) {
    if (now - last_draw_ < std::chrono::milliseconds(100) && done_ < total_) return;
    last_draw_ = now;
    draw(false);
  } else {
    const int decile = static_cast<int>(10 * done_ / total_);
    if (decile != last_decile_) {
      last_decile_ = decile;
      draw(false);
    }
  }
}

void ProgressBar::finish(const std::string& status) {
  if (finished_) return;
  if (!status.empty()) status_ = status;
  draw(true);
  finished_ = true;
}

void ProgressBar::draw(bool final) {
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const double rate = elapsed > 0 ? (done_ - std::max<int64_t>(start_done_, 0)) / elapsed : 0.0;
  const double eta = rate > 0 ? (total_ - done_) / rate : -1.0;
  const int width = 24;
  const int filled = static_cast<int>(width * std::min<int64_t>(done_, total_) / total_);
  std::string bar(filled, '#');
  bar += std::string(width - filled, '.');
  char line[512];
  std::snprintf(line, sizeof(line), "%s [%s] %lld/%lld %.1f %s/s %s %s %s", label_.c_str(),
                bar.c_str(), (long long)done_, (long long)total_, rate, unit_.c_str(),
                final ? "elapsed" : "ETA",
                format_duration(final ? elapsed : eta).c_str(), status_.c_str());
  if (is_tty_)
    std::fprintf(stderr, "\r\033[K%s%s", line, final ? "\n" : "");
  else
    std::fprintf(stderr, "%s\n", line);
  std::fflush(stderr);
}

}  // namespace handscs
