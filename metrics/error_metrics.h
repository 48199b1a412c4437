// Error of an estimate against the reference, per DESIGN §6.
//
// - rms: Cohen et al. 1988 eq. 14, sqrt(sum A_e (B*_e - B_e)^2 / sum A_e);
//   rms_rel = rms / sqrt(sum A_e B*_e^2 / sum A_e), so scenes and channels compare.
// - p-error (Wu & Wang 2002): p_k = (B_k - B*_k) / B*_k, the perceived (relative) error. Elements
//   with B*_k <= 1e-9 of the area-weighted mean of B* carry no meaningful relative error and are
//   left out, counted and their area reported. The mean, not the max: a small bright lamp sets
//   max B* (1e-9 of it dropped the whole room beside a 0.3 mm lamp, issue 35.4), while the mean is
//   power per area, which the lamp cannot raise without lighting the room by as much; an element
//   reflecting rho of the mean irradiance is dropped only when rho * (its irradiance / the mean)
//   is below 1e-9, i.e. when it is dark. Exact zeros (no light arrives) are always left out.
//   Reported: area-weighted mean |p|, area-weighted RMS p, max |p|, and the area fractions
//   over-lit (p > +1%) and under-lit (p < -1%) among the elements kept.
//
// Each is computed on one scalar field: one colour channel, or the mean of the channels
// (kMeanOfChannels; Cohen measures on the mean of the colour bands).
#pragma once

#include <cstddef>
#include <span>

#include "core/radiosity.h"

namespace radlab {

inline constexpr int kMeanOfChannels = -1;
inline constexpr double kPErrorThreshold = 1e-9;  // of the mean of B*: below, p is left out
inline constexpr double kLitTolerance = 0.01;     // |p| beyond which an element is over/under-lit

struct ErrorMetrics {
  double rms = 0.0;
  double rms_rel = 0.0;
  double p_mean = 0.0;
  double p_rms = 0.0;
  double p_max = 0.0;
  double p_over = 0.0;   // area fraction with p > +1%
  double p_under = 0.0;  // area fraction with p < -1%
  size_t p_excluded = 0;
  double p_excluded_area = 0.0;  // area fraction of the elements left out
};

ErrorMetrics compare(const Radiosity& estimate, const Radiosity& reference,
                     std::span<const double> area, int channel);

// The value of element i in the chosen field (a channel, or the mean of channels).
double field_value(const Radiosity& field, size_t i, int channel);

// Cohen's eq. 14 on the reflected part of the field, B - E against B* - E: the emitters, which
// every solver gets right from step 0, drop out. rms_rel divides by the area-weighted RMS of
// B* - E (0 when nothing is reflected: then rms itself).
struct ReflectedRms {
  double rms = 0.0;
  double rms_rel = 0.0;
};
ReflectedRms compare_reflected(const Radiosity& estimate, const Radiosity& reference,
                               const Radiosity& emission, std::span<const double> area,
                               int channel);

// The p-error threshold: kPErrorThreshold times the area-weighted mean of the reference.
double p_error_threshold(const Radiosity& reference, std::span<const double> area, int channel);

// Per-element signed relative error (B - B*) / B* of the chosen field; 0 where B* is at or below
// the p-error threshold. For error images.
void relative_errors(const Radiosity& estimate, const Radiosity& reference,
                     std::span<const double> area, int channel, std::span<double> out);

// Total power sum_i A_i B_i of the chosen field.
double total_power(const Radiosity& field, std::span<const double> area, int channel);

}  // namespace radlab
