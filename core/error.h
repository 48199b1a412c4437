// Errors that reach the user. Each carries the process exit code the command line returns
// (DESIGN §7): 2 usage, 3 invalid input, 4 numerical failure, 5 tolerance not reached. Messages
// name the file, line, element or key at fault; the command line prints them verbatim.
#pragma once

#include <stdexcept>
#include <string>

namespace radlab {

// 5: the run finished and wrote its outputs, but the tolerance it was asked for (--tol) was not
// reached before another budget stopped it.
enum class ExitCode : int {
  kOk = 0,
  kUsage = 2,
  kInvalidInput = 3,
  kNumerical = 4,
  kToleranceNotReached = 5
};

class Error : public std::runtime_error {
 public:
  Error(ExitCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
  ExitCode code() const { return code_; }

 private:
  ExitCode code_;
};

// The command was called wrongly: unknown option, key, solver or scene name.
class UsageError : public Error {
 public:
  explicit UsageError(const std::string& message) : Error(ExitCode::kUsage, message) {}
};

// The input is wrong: a malformed file, an impossible material, a degenerate polygon.
class InputError : public Error {
 public:
  explicit InputError(const std::string& message) : Error(ExitCode::kInvalidInput, message) {}
};

// The numbers went wrong: no finite solution, divergence, stagnation, a failed certificate.
class NumericalError : public Error {
 public:
  explicit NumericalError(const std::string& message) : Error(ExitCode::kNumerical, message) {}
};

}  // namespace radlab
