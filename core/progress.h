// Progress of long work on stderr (never stdout). On a terminal, one line redrawn in place with
// rate, elapsed time and ETA; otherwise (logs, CI, Slurm) a line at the start, one a minute while
// it runs, and one at the end. Silenced by log::set_quiet(true).
#pragma once

#include <chrono>
#include <string>

namespace radlab {

class Progress {
 public:
  // `unit` names what is counted ("rows"), `total` may be 0 when unknown.
  Progress(std::string label, std::string unit, double total);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  // Reports `done` units so far (redraws at most a few times per second). Throws Interrupted
  // when an interrupt was requested (core/interrupt.h: Ctrl-C in the Python module).
  void update(double done);
  // Final line with the total time.
  void finish(const std::string& note = "");

  // The interval between progress lines in a log (default one minute; tests use 0).
  static void set_log_interval(std::chrono::milliseconds interval);

 private:
  std::string label_, unit_;
  double total_;
  bool terminal_;
  bool finished_ = false;
  std::chrono::steady_clock::time_point start_, last_draw_;
};

}  // namespace radlab
