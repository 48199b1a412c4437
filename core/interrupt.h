// A request to stop long work early: Ctrl-C in the Python module (python/src), where the C++ work
// runs without the GIL and Python's own handler cannot act until it returns. A SIGINT handler
// installed for the duration of the work sets the request (async-signal-safe: one atomic store);
// the places long work reports its progress (core/progress.h: matrix builds, on-the-fly rows, a
// run's steps) check it and throw Interrupted, which unwinds the work like any error: caches and
// outputs are written atomically, so nothing half-written is left. The command line never sets
// it (SIGINT ends the process there).
#pragma once

#include "core/error.h"

namespace radlab {

class Interrupted : public Error {
 public:
  Interrupted() : Error(ExitCode::kUsage, "interrupted") {}
};

void request_interrupt() noexcept;  // async-signal-safe
void clear_interrupt() noexcept;
bool interrupt_requested() noexcept;
// Throws Interrupted (and clears the request) when one is pending.
void throw_if_interrupted();

}  // namespace radlab
