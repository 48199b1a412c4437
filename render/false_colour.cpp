// The two error colour maps (see false_colour.h).
#include "render/false_colour.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace radlab {
namespace {

const glm::dvec3 kNoValue(1.0, 0.0, 1.0);  // magenta

// Linear from `neutral` at 0 to `below` at -saturation or `above` at +saturation, then constant.
glm::dvec3 diverging(double value, double saturation, const glm::dvec3& neutral,
                     const glm::dvec3& below, const glm::dvec3& above, const char* caller) {
  if (!(saturation > 0.0) || !std::isfinite(saturation))
    throw std::invalid_argument(std::string(caller) + ": saturation " + std::to_string(saturation) +
                                " must be finite and positive");
  if (!std::isfinite(value)) return kNoValue;
  const double t = std::min(std::abs(value) / saturation, 1.0);
  return (1.0 - t) * neutral + t * (value < 0.0 ? below : above);
}

}  // namespace

glm::dvec3 cohen_error_colour(double relative_error, double saturation) {
  return diverging(relative_error, saturation, glm::dvec3(0.5), glm::dvec3(0.1, 0.2, 1.0),
                   glm::dvec3(1.0, 0.15, 0.1), "cohen_error_colour");
}

glm::dvec3 p_error_colour(double p, double saturation) {
  return diverging(p, saturation, glm::dvec3(0.95), glm::dvec3(0.0, 0.6, 0.2),
                   glm::dvec3(1.0, 0.75, 0.0), "p_error_colour");
}

}  // namespace radlab
