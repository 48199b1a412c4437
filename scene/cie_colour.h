// CIE colorimetry for scene input (the MGF reader): tristimulus values of spectra, chromaticity,
// and the linear RGB space radlab's materials use.
//
// Colour matching functions: the CIE 1931 2-degree observer as approximated by the multi-lobe
// piecewise-Gaussian fit of Wyman, Sloan & Shirley, "Simple Analytic Approximations to the CIE XYZ
// Color Matching Functions", JCGT 2(2), 2013 (deviation from the tabulated functions below about
// 1% of their peaks). Each function is rescaled so that the equal-energy spectrum integrates to
// X = Y = Z exactly, i.e. to the chromaticity (1/3, 1/3) that MGF calls neutral. Spectra are
// integrated on a 1 nm grid over 380..780 nm (trapezoid rule, linear interpolation of samples).
//
// RGB: linear, Rec. 709 / sRGB primaries (0.64, 0.33), (0.30, 0.60), (0.15, 0.06) with the
// equal-energy white E (1/3, 1/3) instead of sRGB's D65. MGF defines reflectances under an
// equal-energy illuminant and calls (1/3, 1/3) neutral, so with this white a neutral MGF colour is
// exactly grey (R = G = B); it is the sRGB gamut white-balanced to E. The luminance of an RGB
// triple is Y = luminance(rgb), and luminance(1, 1, 1) = 1.
#pragma once

#include <glm/vec2.hpp>
#include <span>

#include "scene/scene.h"

namespace radlab::cie {

using Xyz = glm::dvec3;
using Chromaticity = glm::dvec2;

// (x-bar, y-bar, z-bar) at a wavelength in nanometres (rescaled fit, see above).
Xyz colour_matching(double wavelength_nm);

// Tristimulus values of a relative spectrum sampled evenly from `lambda_min` to `lambda_max`
// (nm), as MGF's `cspec` gives it; zero outside that range. Needs at least 2 samples and
// lambda_min < lambda_max. Only the ratios (the chromaticity) are meaningful for MGF.
Xyz spectrum_to_xyz(double lambda_min, double lambda_max, std::span<const double> samples);

// Tristimulus values of a black body at `kelvin` (Planck's law), as MGF's `cct` gives it.
Xyz blackbody_to_xyz(double kelvin);

// (x, y) = (X, Y) / (X + Y + Z). Requires X + Y + Z > 0.
Chromaticity chromaticity(const Xyz& xyz);

// X, Y, Z of the chromaticity (x, y) at luminance Y. Requires y > 0.
Xyz xyY_to_xyz(const Chromaticity& xy, double luminance);

// Linear RGB (Rec. 709 primaries, white E) from XYZ, and back.
Rgb xyz_to_rgb(const Xyz& xyz);
Xyz rgb_to_xyz(const Rgb& rgb);

// The luminance Y of a linear RGB triple.
double luminance(const Rgb& rgb);

}  // namespace radlab::cie
