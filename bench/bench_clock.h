// The benchmarks' clock: CPU time of the calling thread, so a measurement is "on one core" even
// when other processes share the cores (ratios of two such times are what the docs quote).
#pragma once

#include <time.h>

namespace radlab {

inline timespec thread_now() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t;
}

inline double thread_seconds(const timespec& start) {
  const timespec now = thread_now();
  return double(now.tv_sec - start.tv_sec) + 1e-9 * double(now.tv_nsec - start.tv_nsec);
}

}  // namespace radlab
