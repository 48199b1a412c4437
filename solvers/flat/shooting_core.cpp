#include "solvers/flat/shooting_core.h"

#include <cmath>
#include <cstring>

#include "core/error.h"

namespace radlab {

void ShootingCore::init(const System& system) {
  system_ = &system;
  const size_t n = system.size();
  const int channels = system.channels();
  x_ = Radiosity(channels, n);
  dB_ = system.emission();
  // Runs of bitwise-equal reflectance (so that k * rho per run is the per-element product), used
  // when they are long enough on average for the vector loop to run within them.
  runs_.clear();
  const Radiosity& rho = system.reflectance();
  for (size_t j = 0; j < n; ++j) {
    bool same = !runs_.empty();
    for (int c = 0; c < channels && same; ++c) {
      const double value = rho.at(c, j);
      same = std::memcmp(&runs_.back().rho[c], &value, sizeof(double)) == 0;
    }
    if (same) {
      runs_.back().end = j + 1;
      continue;
    }
    kernels::ReflectanceRun run;
    run.end = j + 1;
    for (int c = 0; c < channels; ++c) run.rho[c] = rho.at(c, j);
    runs_.push_back(run);
  }
  if (runs_.size() * kMinimumRun > n) runs_.clear();
  offset_ = nullptr;
  float_ = false;
  dirty_ = true;
}

void ShootingCore::set_float_storage(bool on) {
  float_ = on;
  if (!on) return;
  for (double& v : dB_.raw()) v = double(float(v));
  for (double& v : x_.raw()) v = double(float(v));
  dirty_ = true;
}

kernels::ShotTargets ShootingCore::targets() const {
  kernels::ShotTargets t;
  t.channels = channels();
  // The kernels write through these pointers only in shoot(), a non-const member.
  auto& self = const_cast<ShootingCore&>(*this);
  for (int c = 0; c < channels(); ++c) {
    t.unshot[c] = self.dB_.channel(c).data();
    t.reflectance[c] = system_->reflectance().channel(c).data();
  }
  if (offset_)
    for (int c = 0; c < channels(); ++c) t.offset[c] = offset_->channel(c).data();
  t.area = system_->area().data();
  t.inverse_area = system_->inverse_area().data();
  if (!runs_.empty()) {
    t.runs = runs_.data();
    t.run_count = runs_.size();
  }
  return t;
}

template <class Row>
kernels::Argmax ShootingCore::shoot(const Row& F, size_t i, const double* s, bool select,
                                    double* coverage) {
  if (system_->two_level()) {
    if (coverage)
      throw UsageError("shot coverage (Wu & Wang's dff) is defined for element shooters only");
    return shoot_patch(F, i, s, select);
  }
  const size_t n = size();
  const double Ai = system_->area()[i];
  double k[3] = {0.0, 0.0, 0.0};
  for (int c = 0; c < channels(); ++c) k[c] = Ai * s[c];
  kernels::ShotTargets t = targets();
  t.coverage = coverage;
  const kernels::Argmax before = kernels::shoot(F, 0, i, k, Ai, t, select);
  const kernels::Argmax after = kernels::shoot(F, i + 1, n, k, Ai, t, select);
  // The shooter: its self term (zero for planar elements; the kernels' arithmetic), then its own
  // books.
  const double g = double(F[i]) * system_->inverse_area()[i];
  for (int c = 0; c < channels(); ++c) {
    double& u = dB_.at(c, i);
    u += g * (k[c] * system_->reflectance().at(c, i));
    u -= s[c];
    x_.at(c, i) += s[c];
  }
  dirty_ = true;
  if (float_) {
    for (double& v : dB_.raw()) v = double(float(v));
    for (int c = 0; c < channels(); ++c) x_.at(c, i) = double(float(x_.at(c, i)));
    return select ? max_priority() : kernels::Argmax{};
  }
  if (!select) return {};
  // Ties go to the lowest index: the elements before i, then i, then those after.
  kernels::Argmax best = before;
  const double own = priority(i);
  if (own > best.value) best = {own, i};
  if (after.value > best.value) best = after;
  return best;
}

template <class Row>
kernels::Argmax ShootingCore::shoot_patch(const Row& F, size_t p, const double* s, bool select) {
  const Patches& patches = system_->shooters();
  const auto members = patches.members(p);
  const size_t m = members.size();
  const int C = channels();
  // Each member's share, taken before the row reaches the patch's own elements (their self
  // terms, zero for a planar patch, are delivered like any other receiver's).
  amounts_.resize(m * size_t(C));
  for (int c = 0; c < C; ++c) {
    const double excess = m == 1 ? 0.0 : s[c] - shooter_unshot(c, p);
    for (size_t k = 0; k < m; ++k)
      amounts_[size_t(c) * m + k] = m == 1 ? s[c] : dB_.at(c, members[k]) + excess;
  }
  const double Ap = patches.area(p);
  double k[3] = {0.0, 0.0, 0.0};
  for (int c = 0; c < C; ++c) k[c] = Ap * s[c];
  kernels::ShotTargets t = targets();
  for (int c = 0; c < C; ++c) t.offset[c] = nullptr;  // per shooter here, not per element
  kernels::shoot(F, 0, size(), k, Ap, t, false);
  for (int c = 0; c < C; ++c)
    for (size_t q = 0; q < m; ++q) {
      const double share = amounts_[size_t(c) * m + q];
      dB_.at(c, members[q]) -= share;
      x_.at(c, members[q]) += share;
    }
  dirty_ = true;
  if (!select) return {};
  return max_priority();
}

template kernels::Argmax ShootingCore::shoot(const float* const&, size_t, const double*, bool,
                                             double*);
template kernels::Argmax ShootingCore::shoot(const double* const&, size_t, const double*, bool,
                                             double*);
template kernels::Argmax ShootingCore::shoot(const kernels::RunRow<float>&, size_t, const double*,
                                             bool, double*);
template kernels::Argmax ShootingCore::shoot(const kernels::RunRow<double>&, size_t, const double*,
                                             bool, double*);

double ShootingCore::shooter_unshot(int c, size_t p) const {
  if (!system_->two_level()) return dB_.at(c, p);
  const Patches& patches = system_->shooters();
  const auto members = patches.members(p);
  const auto weights = patches.weights(p);
  double u = 0.0;
  for (size_t k = 0; k < members.size(); ++k) u += weights[k] * dB_.at(c, members[k]);
  return u;
}

double ShootingCore::shooter_reflectance(int c, size_t p) const {
  const Radiosity& rho = system_->reflectance();
  if (!system_->two_level()) return rho.at(c, p);
  const Patches& patches = system_->shooters();
  const auto members = patches.members(p);
  const auto weights = patches.weights(p);
  double r = 0.0;
  for (size_t k = 0; k < members.size(); ++k) r += weights[k] * rho.at(c, members[k]);
  return r;
}

bool ShootingCore::shooter_has_unshot(size_t p) const {
  for (uint32_t e : system_->shooters().members(p))
    for (int c = 0; c < channels(); ++c)
      if (dB_.at(c, e) != 0.0) return true;
  return false;
}

kernels::Argmax ShootingCore::max_priority() const {
  if (!system_->two_level()) return kernels::max_priority(0, size(), targets());
  kernels::Argmax best;
  for (size_t p = 0; p < shooters(); ++p) {
    const double value = priority(p);
    if (value > best.value) best = {value, p};
  }
  return best;
}

double ShootingCore::priority(size_t j) const {
  if (system_->two_level()) {
    // The kernels' order: (0 + |dB_0p (+ o_0p)| + ...) * A_p.
    double p = 0.0;
    for (int c = 0; c < channels(); ++c) {
      const double u = shooter_unshot(c, j);
      p += std::fabs(offset_ ? u + offset_->at(c, j) : u);
    }
    return p * shooter_area(j);
  }
  return element_priority(j);
}

bool ShootingCore::all_shot() const {
  for (double v : dB_.raw())
    if (v != 0.0) return false;
  return true;
}

kernels::Argmax ShootingCore::first_unshot() const {
  for (size_t j = 0; j < size(); ++j)
    for (int c = 0; c < channels(); ++c)
      if (dB_.at(c, j) != 0.0) return {0.0, system_->shooters().patch_of(j)};
  return {};
}

void ShootingCore::unshot_power(bool clamp_negative, double* out) const {
  kernels::unshot_power(targets(), size(), clamp_negative, out);
}

const Radiosity& ShootingCore::solution() const {
  if (dirty_) {
    if (B_.size() != x_.size() || B_.channels() != x_.channels()) B_ = x_;
    auto b = B_.raw();
    auto x = x_.raw();
    auto u = dB_.raw();
    for (size_t k = 0; k < b.size(); ++k) b[k] = x[k] + u[k];
    dirty_ = false;
  }
  return B_;
}

std::vector<double> average_reflectance(const System& system) {
  std::vector<double> rho(size_t(system.channels()), 0.0);
  for (int c = 0; c < system.channels(); ++c) {
    double s = 0.0;
    for (size_t j = 0; j < system.size(); ++j)
      s += system.area()[j] * system.reflectance().at(c, j);
    rho[size_t(c)] = s / system.total_area();
  }
  return rho;
}

std::vector<double> ambient_radiosity(const std::vector<double>& interreflection,
                                      const double* unshot_power, double total_area) {
  std::vector<double> ambient(interreflection.size());
  for (size_t c = 0; c < ambient.size(); ++c)
    ambient[c] = interreflection[c] * unshot_power[c] / total_area;
  return ambient;
}

}  // namespace radlab
