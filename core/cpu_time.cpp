// The process's CPU time: clock_gettime's per-process clock (POSIX).
#include "core/cpu_time.h"

#include <time.h>

namespace radlab {

double process_cpu_seconds() {
  timespec t{};
  if (clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t) != 0) return 0.0;  // POSIX guarantees this clock
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

}  // namespace radlab
