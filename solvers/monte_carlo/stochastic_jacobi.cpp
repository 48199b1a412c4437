// stochastic-jacobi — stochastic relaxation radiosity (Neumann, Feda, Kopp & Tobler 1994/95;
// Bekaert, PhD thesis, KU Leuven 1999, ch. 4–6).
//
// Method: Jacobi iteration B' = E + R B (R = diag(rho) F) with R B estimated by Monte Carlo
//   power propagation (power_propagation.h): N rays from elements chosen in proportion to the
//   power they propagate, uniform points on them, cosine-distributed directions, closest hit by
//   Embree on the run's mesh; a hit on j deposits rho_j (power per ray) / A_j. Matrix-free: no
//   form-factor row is read (System::with_row is never called), memory is O(n + rays per block).
//   Piecewise constant on the run's mesh, per colour channel (the power that picks the source is
//   summed over channels; every ray carries each channel's share).
// Phases:
//   incremental  B = dB = E; each step propagates the unshot dB: dB <- R~ dB, B += dB. Ends
//                when what it has still to add, bounded by the geometric tail U r/(1-r) of the
//                unshot power U = sum_i A_i |dB_i| (r the largest reflectance), is at most
//                kIncrementalUntil (1%) of the total power sum_i A_i |B_i| (or after
//                kMaxIncrementalSteps = 100 steps: at r = 1 the tail never shrinks).
//                solution() = B.
//   regular      each step re-propagates the total: B^(k) = E + R~ B^(k-1), from B^(0) = the
//                incremental result; solution() = the mean of B^(1..K) over the K regular steps
//                so far (Bekaert §6.2).
// Bias: R~ x is unbiased for R x for any x (power_propagation.h), so by linearity
//   E[B^(k)] = J^k E[B^(0)] with J B = E + R B, the deterministic Jacobi iterates, and the
//   incremental result estimates the truncated Neumann series sum_{m<=k} R^m E without bias.
//   The average of the regular iterates therefore has expectation (1/K) sum_k J^k E[B^(0)]:
//   biased low by (1/K) sum_k R^k (B* - E[B^(0)]): the incremental phase's deficit (about 1%
//   of the total power at the switch, by the criterion above), shrinking by rho per step and
//   diluted by 1/K. (An earlier criterion, unshot <= 1% of the total, left 8% at rho = 0.9, and
//   a 2% bias after 60 steps on builtin:cube:rho=0.9.) It is not
//   unbiased for B*, and the bias falls as 1/K (the variance too, as 1/(K N), up to the
//   iterates' correlation). The expectation is the solution of the exact-F system, not of the
//   certified reference's raycast F: the two differ by the reference's form-factor error.
// Control variate (Bekaert §6.3): regular steps propagate B - beta instead of B and add
//   beta R 1 = beta rho_j sum_i F_ji back: B^(k) = E + R~ (B^(k-1) - beta) + beta rho S~, with
//   S~_j the fraction of cosine rays from j that land on an element (estimated once, at the first
//   regular step, from max(4, ceil(N/n)) rays per element, from its own stream; exactly 1 in a
//   closed scene). beta is fixed at the first regular step: the given constant, or (`true`) per
//   channel the area-weighted median of the incremental result, the constant that minimises the
//   propagated power sum_i A_i |B_i - beta| (the estimator's standard deviation is at most that
//   power over sqrt(N)). beta and S~ are then independent of each other, so the estimate stays
//   as unbiased as without it.
// Sequences: pseudo (PCG32 streams from the seed) or sobol (Boost.Random's Sobol' points in five
//   dimensions, continuing from step to step, with a random shift from the seed per dimension:
//   randomised quasi-Monte Carlo, unbiased for every seed, errors falling faster than N^-1/2).
// Parameters: rays (per step, > 0 and at most --limits rays=, InputError beyond), control_variate
// (false, true or a constant >= 0), sequence
//   (pseudo or sobol), seed; defaults: `radlab solvers` (StochasticJacobiOptions).
// Cost per step: `rays` rays (the first regular step with a control variate adds the landing
//   estimate's rays). Work charged: every ray cast with charge_rays and as one element-pair
//   form-factor evaluation (a ray samples one pair i -> j, the unit of a flat row's n).
// Left out: RenderPark's bidirectional lines and its ray-unit heuristics, higher-order (non
//   constant) bases, importance.
#include <algorithm>
#include <cmath>
#include <memory>
#include <numeric>
#include <string>

#include "core/error.h"
#include "core/limits.h"
#include "core/random.h"
#include "solvers/monte_carlo/power_propagation.h"
#include "solvers/monte_carlo/ray_sampler.h"
#include "solvers/solver_factories.h"

namespace radlab {
namespace {

using namespace monte_carlo;

// The incremental phase ends when the power it has still to add is at most this share of the
// total.
constexpr double kIncrementalUntil = 1e-2;
// ... or after this many steps: with rho near 1 the unshot power barely falls.
constexpr long long kMaxIncrementalSteps = 100;

struct StochasticJacobiOptions {
  long long rays = 10000;
  std::string control_variate = "false";
  std::string sequence = "pseudo";
  long long seed = 1;

  // The constant beta: < 0 means none, NaN means "choose" (the weighted median).
  double beta = -1.0;

  static StochasticJacobiOptions from(ParamBag& bag) {
    StochasticJacobiOptions o;
    o.rays = bag.get_int("rays", o.rays, 1, kInt64Max);
    o.control_variate = bag.get_string("control_variate", o.control_variate);
    o.sequence = bag.get_choice("sequence", o.sequence, {"pseudo", "sobol"});
    o.seed = bag.get_int("seed", o.seed);
    o.validate();
    // A value given is checked here, before any work; the default (no key: also the registry's
    // reading of the defaults, which must not fail) at init().
    if (bag.has("rays")) o.check_rays_limit();
    return o;
  }

  void check_rays_limit() const {
    check_limit("rays", double(rays),
                "stochastic-jacobi: rays=" + std::to_string(rays) + " rays per step");
  }

  void validate() {
    if (seed < 0)
      throw UsageError("stochastic-jacobi: seed must be >= 0, got " + std::to_string(seed));
    const std::string& cv = control_variate;
    if (cv == "false" || cv == "0" || cv == "no" || cv == "off") {
      beta = -1.0;
      return;
    }
    if (cv == "true" || cv == "yes" || cv == "on") {
      beta = std::nan("");
      return;
    }
    size_t used = 0;
    double value = std::nan("");
    try {
      value = std::stod(cv, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != cv.size() || !std::isfinite(value) || value < 0.0)
      throw UsageError(
          "stochastic-jacobi: control_variate must be true, false or a finite constant >= 0, "
          "got '" +
          cv + "'");
    beta = value;
  }
};

// The area-weighted median of one channel: the beta that minimises sum_i A_i |x_i - beta|.
double weighted_median(std::span<const double> x, std::span<const double> area) {
  std::vector<size_t> order(x.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return x[a] < x[b]; });
  const double half = 0.5 * std::accumulate(area.begin(), area.end(), 0.0);
  double seen = 0.0;
  for (size_t i : order) {
    seen += area[i];
    if (seen >= half) return x[i];
  }
  return x.empty() ? 0.0 : x[order.back()];
}

class StochasticJacobiSolver final : public Solver {
 public:
  explicit StochasticJacobiSolver(StochasticJacobiOptions options) : o_(std::move(options)) {}

  void init(const System& system) override {
    o_.check_rays_limit();
    system_ = &system;
    rays_tracer_ = std::make_unique<ElementRays>(system.mesh());
    propagation_ =
        std::make_unique<PowerPropagation>(system.mesh(), system.reflectance(), *rays_tracer_);
    const uint64_t seed = uint64_t(o_.seed);
    stream_ = o_.sequence == "sobol" ? make_sobol_stream(seed) : make_pseudo_stream(seed);
    // The landing estimate's own stream, independent of the one above.
    landing_stream_ = make_pseudo_stream(hash_combine(seed, 0x1a4d17u));
    block_ = landing_block_ = 0;
    B_ = system.emission();
    unshot_ = system.emission();
    solution_ = B_;
    sum_ = Radiosity(system.channels(), system.size());
    incremental_steps_ = regular_steps_ = 0;
    regular_ = false;
    rays_ = landing_rays_ = 0;
    beta_[0] = beta_[1] = beta_[2] = 0.0;
    landing_.clear();
    // Nothing to propagate (no emitter), or nothing reflects: B = E is exact (as the
    // deterministic solvers, the run then stops at once).
    done_ = power(B_) == 0.0 || system.max_reflectance() == 0.0;
  }

  StepInfo step() override {
    if (done_) return {.finished = true};
    if (!regular_)
      incremental_step();
    else
      regular_step();
    return {};
  }

  const Radiosity& solution() const override { return solution_; }

  std::vector<std::pair<std::string, double>> statistics() const override {
    std::vector<std::pair<std::string, double>> s = {
        {"incremental_steps", double(incremental_steps_)},
        {"regular_steps", double(regular_steps_)},
        {"rays", double(rays_ + landing_rays_)},
        {"landing_rays", double(landing_rays_)},
    };
    if (o_.beta >= 0.0 || std::isnan(o_.beta))
      for (int c = 0; c < system_->channels(); ++c)
        s.emplace_back("control_variate" +
                           (system_->channels() == 1 ? std::string() : "." + std::to_string(c)),
                       beta_[c]);
    return s;
  }

 private:
  // sum_i A_i |x_i| summed over channels.
  double power(const Radiosity& x) const {
    double p = 0.0;
    for (int c = 0; c < x.channels(); ++c)
      for (size_t i = 0; i < x.size(); ++i) p += system_->area()[i] * std::abs(x.at(c, i));
    return p;
  }

  void charge(uint64_t rays) {
    system_->charge_rays(rays);
    system_->charge_pair_evaluations(rays);
  }

  void incremental_step() {
    Radiosity deposit;
    const uint64_t cast =
        propagation_->propagate(unshot_, uint64_t(o_.rays), *stream_, &block_, deposit);
    rays_ += cast;
    charge(cast);
    for (size_t k = 0; k < B_.raw().size(); ++k) B_.raw()[k] += deposit.raw()[k];
    unshot_ = std::move(deposit);
    solution_ = B_;
    ++incremental_steps_;
    // What the incremental phase has still to add, were it to go on: the unshot power and its
    // reflections, at most unshot x r/(1-r) with r the largest reflectance (a geometric tail).
    const double r = system_->max_reflectance();
    const bool tail_small =
        r < 1.0 && power(unshot_) * r / (1.0 - r) <= kIncrementalUntil * power(B_);
    if (tail_small || incremental_steps_ >= kMaxIncrementalSteps) regular_ = true;
  }

  void regular_step() {
    const int channels = system_->channels();
    const bool control = o_.beta >= 0.0 || std::isnan(o_.beta);
    if (control && regular_steps_ == 0) {
      // beta and S~ fixed once, from what precedes the regular phase (see the top).
      for (int c = 0; c < channels; ++c)
        beta_[c] = std::isnan(o_.beta) ? weighted_median(B_.channel(c), system_->area()) : o_.beta;
      const uint64_t per_element =
          std::max<uint64_t>(4, (uint64_t(o_.rays) + system_->size() - 1) / system_->size());
      const uint64_t cast =
          propagation_->landing_fraction(per_element, *landing_stream_, &landing_block_, landing_);
      landing_rays_ += cast;
      charge(cast);
    }
    // Into buffers kept from step to step (fresh ones cost page faults every step).
    Radiosity& source = source_;
    Radiosity& deposit = deposit_;
    source = B_;
    if (control)
      for (int c = 0; c < channels; ++c)
        for (double& b : source.channel(c)) b -= beta_[c];
    const uint64_t cast =
        propagation_->propagate(source, uint64_t(o_.rays), *stream_, &block_, deposit);
    rays_ += cast;
    charge(cast);
    const Radiosity& E = system_->emission();
    const Radiosity& rho = system_->reflectance();
    for (int c = 0; c < channels; ++c)
      for (size_t j = 0; j < system_->size(); ++j) {
        double b = E.at(c, j) + deposit.at(c, j);
        if (control) b += beta_[c] * rho.at(c, j) * landing_[j];
        B_.at(c, j) = b;
        sum_.at(c, j) += b;
      }
    ++regular_steps_;
    const double inverse = 1.0 / double(regular_steps_);
    for (size_t k = 0; k < sum_.raw().size(); ++k) solution_.raw()[k] = sum_.raw()[k] * inverse;
  }

  StochasticJacobiOptions o_;
  const System* system_ = nullptr;
  std::unique_ptr<ElementRays> rays_tracer_;
  std::unique_ptr<PowerPropagation> propagation_;
  std::unique_ptr<UniformStream> stream_, landing_stream_;
  uint64_t block_ = 0, landing_block_ = 0;
  Radiosity B_, unshot_, sum_, solution_;
  Radiosity source_, deposit_;  // regular_step's buffers
  std::vector<double> landing_;
  double beta_[3] = {0.0, 0.0, 0.0};
  long long incremental_steps_ = 0, regular_steps_ = 0;
  uint64_t rays_ = 0, landing_rays_ = 0;
  bool regular_ = false, done_ = false;
};

}  // namespace

SolverInfo stochastic_jacobi_solver_info() {
  return {"stochastic-jacobi",
          "stochastic relaxation: Jacobi with R B estimated by power-proportional cosine rays "
          "(incremental, then averaged regular steps); matrix-free",
          "Neumann et al. 1994/95; Bekaert 1999 (KU Leuven) ch. 4-6",
          "`rays` rays (one ray = one pair evaluation)",
          {{"rays", "", "rays cast per step (> 0)"},
           {"control_variate", "",
            "constant control variate of the regular steps: false, true (area-weighted median) "
            "or the constant (>= 0)"},
           {"sequence", "", "random numbers: pseudo (PCG32) or sobol (randomly shifted Sobol')"},
           {"seed", "", "seed of the rays (and of the Sobol' shift)"}},
          [](ParamBag& bag) -> std::unique_ptr<Solver> {
            return std::make_unique<StochasticJacobiSolver>(StochasticJacobiOptions::from(bag));
          },
          SolverKind::kOther,
          /*matrix_free=*/true};
}

}  // namespace radlab
