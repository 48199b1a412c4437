// Diagnostics on stderr. Results go to files or stdout; everything a human reads while a command
// runs (warnings, progress) goes to stderr so that piping stdout stays clean.
#pragma once

#include <string>

namespace radlab::log {

// Silences info() and progress output (warnings still print).
void set_quiet(bool quiet);
bool quiet();

void info(const std::string& message);
void warning(const std::string& message);

// True when stderr is a terminal: progress then redraws one line instead of appending lines.
bool stderr_is_terminal();

}  // namespace radlab::log
