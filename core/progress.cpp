#include "core/progress.h"

#include <cstdio>

#include "core/interrupt.h"
#include "core/log.h"

namespace radlab {

namespace {
// How often a log (not a terminal) gets a progress line; tests shorten it.
std::chrono::milliseconds log_interval{60000};

std::string format_seconds(double s) {
  char buffer[32];
  if (s < 60)
    std::snprintf(buffer, sizeof buffer, "%.1fs", s);
  else if (s < 3600)
    std::snprintf(buffer, sizeof buffer, "%dm%02ds", int(s) / 60, int(s) % 60);
  else
    std::snprintf(buffer, sizeof buffer, "%dh%02dm", int(s) / 3600, (int(s) / 60) % 60);
  return buffer;
}
}  // namespace

Progress::Progress(std::string label, std::string unit, double total)
    : label_(std::move(label)),
      unit_(std::move(unit)),
      total_(total),
      terminal_(log::stderr_is_terminal()),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_) {
  if (!log::quiet() && !terminal_) std::fprintf(stderr, "%s ...\n", label_.c_str());
}

Progress::~Progress() {
  if (!finished_ && terminal_ && !log::quiet()) std::fprintf(stderr, "\n");
}

void Progress::update(double done) {
  throw_if_interrupted();  // long work reports here: where a Ctrl-C from Python stops it
  if (log::quiet()) return;
  const auto now = std::chrono::steady_clock::now();
  // A terminal is redrawn a few times a second; a log (a Slurm job, CI, a redirected run of
  // many minutes) gets a whole line once a minute, so a long build shows that it is moving.
  const auto interval = terminal_ ? std::chrono::milliseconds(200) : log_interval;
  if (now - last_draw_ < interval) return;
  last_draw_ = now;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double rate = elapsed > 0 ? done / elapsed : 0.0;
  std::string eta = "?";
  if (total_ > 0 && rate > 0) eta = format_seconds((total_ - done) / rate);
  const char* begin = terminal_ ? "\r" : "";
  const char* end = terminal_ ? "   " : "\n";
  if (total_ > 0)
    std::fprintf(stderr, "%s%s: %.0f/%.0f %s (%.3g %s/s), %s elapsed, ETA %s%s", begin,
                 label_.c_str(), done, total_, unit_.c_str(), rate, unit_.c_str(),
                 format_seconds(elapsed).c_str(), eta.c_str(), end);
  else
    std::fprintf(stderr, "%s%s: %.0f %s (%.3g %s/s), %s elapsed%s", begin, label_.c_str(), done,
                 unit_.c_str(), rate, unit_.c_str(), format_seconds(elapsed).c_str(), end);
  std::fflush(stderr);
}

void Progress::set_log_interval(std::chrono::milliseconds interval) {
  log_interval = interval;
}

void Progress::finish(const std::string& note) {
  if (finished_) return;
  finished_ = true;
  if (log::quiet()) return;
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  std::fprintf(stderr, "%s%s: done in %s%s%s\n", terminal_ ? "\r" : "", label_.c_str(),
               format_seconds(elapsed).c_str(), note.empty() ? "" : ", ", note.c_str());
}

}  // namespace radlab
