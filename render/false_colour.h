// False-colour maps for error images (values in [0,1] RGB, for write_png_ldr).
#pragma once

#include <glm/vec3.hpp>

namespace radlab {

// Cohen et al. 1988 (Figs 2–5): grey where the estimate is exact, blue where it under-estimates,
// red where it over-estimates; the colour saturates at |relative error| = `saturation`.
glm::dvec3 cohen_error_colour(double relative_error, double saturation = 1.0);

// Signed p-error on a diverging map: green for under-lit (p < 0), white at 0, yellow–orange for
// over-lit (p > 0), as Wu & Wang colour their Figs 5–8; saturates at |p| = `saturation`.
glm::dvec3 p_error_colour(double p, double saturation = 0.5);

}  // namespace radlab
