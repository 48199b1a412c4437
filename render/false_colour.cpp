#include "render/false_colour.h"

#include <algorithm>
#include <cmath>

namespace radlab {

glm::dvec3 cohen_error_colour(double e, double saturation) {
  const glm::dvec3 grey(0.5), blue(0.1, 0.2, 1.0), red(1.0, 0.15, 0.1);
  if (!std::isfinite(e)) return glm::dvec3(1.0, 0.0, 1.0);  // magenta: no value
  const double t = std::clamp(std::abs(e) / saturation, 0.0, 1.0);
  return e < 0 ? (1 - t) * grey + t * blue : (1 - t) * grey + t * red;
}

glm::dvec3 p_error_colour(double p, double saturation) {
  const glm::dvec3 white(0.95), green(0.0, 0.6, 0.2), yellow(1.0, 0.75, 0.0);
  if (!std::isfinite(p)) return glm::dvec3(1.0, 0.0, 1.0);
  const double t = std::clamp(std::abs(p) / saturation, 0.0, 1.0);
  return p < 0 ? (1 - t) * white + t * green : (1 - t) * white + t * yellow;
}

}  // namespace radlab
