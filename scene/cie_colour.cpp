#include "scene/cie_colour.h"

#include <cmath>
#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>

namespace radlab::cie {
namespace {

constexpr double kLambdaMin = 380.0;
constexpr double kLambdaMax = 780.0;
constexpr int kSteps = 400;  // 1 nm

// One lobe of the fit: a Gaussian with different widths left and right of its centre.
double lobe(double lambda, double centre, double sigma_left, double sigma_right) {
  const double t = (lambda - centre) / (lambda < centre ? sigma_left : sigma_right);
  return std::exp(-0.5 * t * t);
}

// The unscaled multi-lobe fit (Wyman, Sloan & Shirley 2013, their eq. 2).
Xyz fitted_cmf(double l) {
  return {1.056 * lobe(l, 599.8, 37.9, 31.0) + 0.362 * lobe(l, 442.0, 16.0, 26.7) -
              0.065 * lobe(l, 501.1, 20.4, 26.2),
          0.821 * lobe(l, 568.8, 46.9, 40.5) + 0.286 * lobe(l, 530.9, 16.3, 31.1),
          1.217 * lobe(l, 437.0, 11.8, 36.0) + 0.681 * lobe(l, 459.0, 26.0, 13.8)};
}

// Trapezoid weight of grid point k.
double weight(int k) {
  return (k == 0 || k == kSteps) ? 0.5 : 1.0;
}
double grid(int k) {
  return kLambdaMin + (kLambdaMax - kLambdaMin) * k / kSteps;
}

// Per-channel factors that make the equal-energy spectrum integrate to X = Y = Z.
const Xyz& white_scale() {
  static const Xyz scale = [] {
    Xyz sum(0.0);
    for (int k = 0; k <= kSteps; ++k) sum += weight(k) * fitted_cmf(grid(k));
    return Xyz(sum.y / sum.x, 1.0, sum.y / sum.z);
  }();
  return scale;
}

struct RgbSpace {
  glm::dmat3 rgb_to_xyz;
  glm::dmat3 xyz_to_rgb;
};

const RgbSpace& rgb_space() {
  static const RgbSpace space = [] {
    const Chromaticity primaries[3] = {{0.64, 0.33}, {0.30, 0.60}, {0.15, 0.06}};
    glm::dmat3 p;  // columns: XYZ of each primary at Y = 1
    for (int i = 0; i < 3; ++i) p[i] = xyY_to_xyz(primaries[i], 1.0);
    const Xyz white = xyY_to_xyz({1.0 / 3.0, 1.0 / 3.0}, 1.0);  // E: (1, 1, 1)
    const Xyz s = glm::inverse(p) * white;
    RgbSpace out;
    for (int i = 0; i < 3; ++i) out.rgb_to_xyz[i] = s[i] * p[i];
    out.xyz_to_rgb = glm::inverse(out.rgb_to_xyz);
    return out;
  }();
  return space;
}

}  // namespace

Xyz colour_matching(double wavelength_nm) {
  return fitted_cmf(wavelength_nm) * white_scale();
}

Xyz spectrum_to_xyz(double lambda_min, double lambda_max, std::span<const double> samples) {
  if (samples.size() < 2 || !(lambda_min < lambda_max)) return Xyz(0.0);
  const double step = (lambda_max - lambda_min) / double(samples.size() - 1);
  Xyz sum(0.0);
  for (int k = 0; k <= kSteps; ++k) {
    const double l = grid(k);
    if (l < lambda_min || l > lambda_max) continue;
    const double position = (l - lambda_min) / step;
    size_t i = static_cast<size_t>(position);
    if (i >= samples.size() - 1) i = samples.size() - 2;
    const double t = position - double(i);
    const double value = (1.0 - t) * samples[i] + t * samples[i + 1];
    sum += weight(k) * value * colour_matching(l);
  }
  return sum;
}

Xyz blackbody_to_xyz(double kelvin) {
  constexpr double c2 = 1.438776877e-2;  // second radiation constant h c / k, m K
  Xyz sum(0.0);
  for (int k = 0; k <= kSteps; ++k) {
    const double metres = grid(k) * 1e-9;
    // Relative spectral exitance; the constant factor 2 pi h c^2 does not change chromaticity.
    const double planck = 1.0 / (std::pow(metres * 1e6, 5.0) * std::expm1(c2 / (metres * kelvin)));
    sum += weight(k) * planck * colour_matching(grid(k));
  }
  return sum;
}

Chromaticity chromaticity(const Xyz& xyz) {
  const double total = xyz.x + xyz.y + xyz.z;
  return {xyz.x / total, xyz.y / total};
}

Xyz xyY_to_xyz(const Chromaticity& xy, double luminance_y) {
  return {xy.x / xy.y * luminance_y, luminance_y, (1.0 - xy.x - xy.y) / xy.y * luminance_y};
}

Rgb xyz_to_rgb(const Xyz& xyz) {
  return rgb_space().xyz_to_rgb * xyz;
}
Xyz rgb_to_xyz(const Rgb& rgb) {
  return rgb_space().rgb_to_xyz * rgb;
}
double luminance(const Rgb& rgb) {
  return rgb_to_xyz(rgb).y;
}

}  // namespace radlab::cie
