// The process's CPU time (every thread's, user + system), read beside the wall clock. On a loaded
// machine a run's wall seconds also measure the other work sharing its cores; its CPU seconds do
// not, so two runs timed at different loads compare by CPU time (docs/outputs.md `cpu_seconds`).
#pragma once

namespace radlab {

// Seconds of CPU the whole process has used so far (CLOCK_PROCESS_CPUTIME_ID). A run of radlab
// runs one solver at a time, so the difference over a solver's steps is that solver's CPU time,
// its worker threads included.
double process_cpu_seconds();

}  // namespace radlab
