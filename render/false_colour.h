// False-colour maps for error images: a signed per-element error becomes a display RGB in [0,1]
// (for write_png_ldr, which applies no tone curve). Each map is linear in |error| from its
// neutral colour to its full colour and saturates at |error| = `saturation`; non-finite errors
// (no reference value to compare with) show as magenta (1, 0, 1), a colour neither map uses.
#pragma once

#include <glm/vec3.hpp>

namespace radlab {

// Cohen et al. 1988's pseudo-colour (Figs. 2-5): grey (0.5) where the estimate is exact, blue
// (0.1, 0.2, 1) where it under-estimates (e < 0), red (1, 0.15, 0.1) where it over-estimates.
// `relative_error` is (B - B*) / B*; the default saturation 1 makes "nothing arrived yet"
// (e = -1) full blue. Throws std::invalid_argument unless saturation > 0.
glm::dvec3 cohen_error_colour(double relative_error, double saturation = 1.0);

// Signed p-error of Wu & Wang 2002 (p = (B - B*) / B*) on a diverging map as in their Figs. 5-8:
// green (0, 0.6, 0.2) for under-illumination (p < 0), near-white (0.95) at 0, yellow
// (1, 0.75, 0) for over-illumination. Throws std::invalid_argument unless saturation > 0.
glm::dvec3 p_error_colour(double p, double saturation = 0.5);

}  // namespace radlab
