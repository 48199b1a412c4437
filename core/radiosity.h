// Per-element values in one or three colour channels: radiosities, emissions, reflectances,
// unshot radiosity. Channel-major storage (all of channel 0, then channel 1, ...) so that the
// solvers' inner loops stream one contiguous array per channel.
//
// A grey scene uses one channel (DESIGN §2: leave out what the scene does not need); rgb() then
// repeats it, so outputs always have three columns.
#pragma once

#include <cassert>
#include <cstddef>
#include <glm/vec3.hpp>
#include <span>
#include <vector>

namespace radlab {

class Radiosity {
 public:
  Radiosity() = default;
  Radiosity(int channels, size_t elements, double value = 0.0)
      : channels_(channels), elements_(elements), data_(size_t(channels) * elements, value) {
    assert(channels == 1 || channels == 3);
  }

  int channels() const { return channels_; }
  size_t size() const { return elements_; }

  std::span<double> channel(int c) { return {data_.data() + size_t(c) * elements_, elements_}; }
  std::span<const double> channel(int c) const {
    return {data_.data() + size_t(c) * elements_, elements_};
  }
  double& at(int c, size_t i) { return data_[size_t(c) * elements_ + i]; }
  double at(int c, size_t i) const { return data_[size_t(c) * elements_ + i]; }

  // The value of element i in RGB (a grey field repeats its one channel).
  glm::dvec3 rgb(size_t i) const {
    if (channels_ == 1) return glm::dvec3(data_[i]);
    return {data_[i], data_[elements_ + i], data_[2 * elements_ + i]};
  }
  // The mean over channels (Cohen 1988 measures error on this).
  double mean(size_t i) const {
    if (channels_ == 1) return data_[i];
    return (data_[i] + data_[elements_ + i] + data_[2 * elements_ + i]) / 3.0;
  }

  std::span<double> raw() { return data_; }
  std::span<const double> raw() const { return data_; }

 private:
  int channels_ = 0;
  size_t elements_ = 0;
  std::vector<double> data_;
};

}  // namespace radlab
