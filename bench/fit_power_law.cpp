// fit_power_law: the growth exponent of measured points for scripts (scripts/floors_scaling.py),
// through radlab's Ceres fit (metrics/power_law_fit.h). Reads lines "s,y" from standard input
// and prints "p sigma C" for y ~ C s^p, sigma the 1-sigma of p.
//   printf '1000,5\n2000,11\n4000,19\n' | build/bench/fit_power_law
// Exit 3 on a line that is not two numbers (naming it), 4 when the fit is not valid (saying why).
#include <cstdio>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/text.h"
#include "metrics/power_law_fit.h"

int main() {
  std::vector<double> s, y;
  std::string line;
  for (int number = 1; std::getline(std::cin, line); ++number) {
    if (line.empty()) continue;
    const size_t comma = line.find(',');
    const auto first = comma == std::string::npos
                           ? std::nullopt
                           : radlab::text::parse_double(line.substr(0, comma));
    const auto second = comma == std::string::npos
                            ? std::nullopt
                            : radlab::text::parse_double(line.substr(comma + 1));
    if (!first || !second) {
      std::fprintf(stderr, "fit_power_law: standard input line %d: expected 's,y', got '%s'\n",
                   number, line.c_str());
      return int(radlab::ExitCode::kInvalidInput);
    }
    s.push_back(*first);
    y.push_back(*second);
  }
  const radlab::PowerLawFit fit = radlab::fit_power_law(s, y);
  if (!fit.valid) {
    std::fprintf(stderr, "fit_power_law: no fit: %s\n", fit.reason.c_str());
    return int(radlab::ExitCode::kNumerical);
  }
  std::printf("%.17g %.17g %.17g\n", fit.exponent, fit.exponent_sigma, fit.constant);
  return 0;
}
