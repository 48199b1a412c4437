#include "metrics/error_metrics.h"

#include <algorithm>
#include <cmath>

namespace radlab {

double field_value(const Radiosity& field, size_t i, int channel) {
  if (channel == kMeanOfChannels) return field.mean(i);
  return field.at(field.channels() == 1 ? 0 : channel, i);
}

double p_error_threshold(const Radiosity& reference, std::span<const double> area, int channel) {
  double power = 0.0, total_area = 0.0;
  for (size_t i = 0; i < reference.size(); ++i) {
    power += area[i] * field_value(reference, i, channel);
    total_area += area[i];
  }
  return total_area > 0 ? kPErrorThreshold * power / total_area : 0.0;
}

ErrorMetrics compare(const Radiosity& estimate, const Radiosity& reference,
                     std::span<const double> area, int channel) {
  ErrorMetrics m;
  const size_t n = reference.size();
  double total_area = 0.0, squared = 0.0, ref_squared = 0.0;
  const double threshold = p_error_threshold(reference, area, channel);
  double excluded_area = 0.0;
  double kept_area = 0.0, p_abs = 0.0, p_sq = 0.0, over = 0.0, under = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const double b = field_value(estimate, i, channel);
    const double r = field_value(reference, i, channel);
    total_area += area[i];
    squared += area[i] * (b - r) * (b - r);
    ref_squared += area[i] * r * r;
    if (r <= threshold) {
      ++m.p_excluded;
      excluded_area += area[i];
      continue;
    }
    const double p = (b - r) / r;
    kept_area += area[i];
    p_abs += area[i] * std::abs(p);
    p_sq += area[i] * p * p;
    m.p_max = std::max(m.p_max, std::abs(p));
    if (p > kLitTolerance) over += area[i];
    if (p < -kLitTolerance) under += area[i];
    if (std::isnan(p)) m.p_max = p;  // make a NaN estimate visible, never hide it
  }
  m.rms = std::sqrt(squared / total_area);
  const double ref_rms = std::sqrt(ref_squared / total_area);
  m.rms_rel = ref_rms > 0 ? m.rms / ref_rms : m.rms;
  m.p_excluded_area = total_area > 0 ? excluded_area / total_area : 0.0;
  if (kept_area > 0) {
    m.p_mean = p_abs / kept_area;
    m.p_rms = std::sqrt(p_sq / kept_area);
    m.p_over = over / kept_area;
    m.p_under = under / kept_area;
  }
  return m;
}

ReflectedRms compare_reflected(const Radiosity& estimate, const Radiosity& reference,
                               const Radiosity& emission, std::span<const double> area,
                               int channel) {
  ReflectedRms m;
  double total_area = 0.0, squared = 0.0, ref_squared = 0.0;
  for (size_t i = 0; i < reference.size(); ++i) {
    const double e = field_value(emission, i, channel);
    const double b = field_value(estimate, i, channel) - e;
    const double r = field_value(reference, i, channel) - e;
    total_area += area[i];
    squared += area[i] * (b - r) * (b - r);
    ref_squared += area[i] * r * r;
  }
  m.rms = std::sqrt(squared / total_area);
  const double ref_rms = std::sqrt(ref_squared / total_area);
  m.rms_rel = ref_rms > 0 ? m.rms / ref_rms : m.rms;
  return m;
}

void relative_errors(const Radiosity& estimate, const Radiosity& reference,
                     std::span<const double> area, int channel, std::span<double> out) {
  const double threshold = p_error_threshold(reference, area, channel);
  for (size_t i = 0; i < reference.size(); ++i) {
    const double r = field_value(reference, i, channel);
    out[i] = r > threshold ? (field_value(estimate, i, channel) - r) / r : 0.0;
  }
}

double total_power(const Radiosity& field, std::span<const double> area, int channel) {
  double power = 0.0;
  for (size_t i = 0; i < field.size(); ++i) power += area[i] * field_value(field, i, channel);
  return power;
}

}  // namespace radlab
