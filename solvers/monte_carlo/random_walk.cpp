// random-walk — discrete random-walk radiosity: shooting walks from the emitters or gathering
// walks from the elements, with survival by reflectance and the collision, absorption or
// survival estimator (Sbert 1993; Bekaert, PhD thesis, KU Leuven 1999, ch. 5; Sbert, Bekaert &
// Halton VMV 2001; RenderPark's `-radiance-method RandomWalk`).
//
// Every ray is element_rays.h's: a uniform point on the element the walk is at, a cosine
// direction, Embree's closest front-face hit, so a step from i lands on j with probability F_ij
// of the discretised system. The walks are *discrete*: each bounce restarts from a fresh uniform
// point on the element hit, not from the hit point (a continuous walk estimates the continuous
// equation, not this mesh's system). Matrix-free (no form-factor row is read), memory O(n) plus
// one block of walks.
//
// Survival. At each element k a walk lands on it survives with probability s_k = max_c rho_kc
// (the largest channel's reflectance; grey scenes: rho_k, the analog walk) and then carries on
// with weights w_c rho_kc / s_k (Russian roulette: unbiased for any s_k > 0, and with s_k the
// largest channel no weight ever grows). A walk also ends when its ray escapes or meets a back
// face. Walks at rho -> 1 must end: a scene with any reflectance >= 1 is refused (InputError,
// exit 3, naming the element and channel), even where the system has a finite solution (hosp.mgf
// has an element reflecting 1 in red: refused there; stochastic-jacobi runs). Below 1 the walk
// length is geometric, at most 1/(1 - max rho) bounces on average, so no cap (and no cap's bias) is
// needed.
//
// Shooting walks (`walks=shooting`) estimate the reflected power P_j - Phi_j = rho_j I_j (I_j the
//   power arriving at j): a walk starts on emitter i with probability p_i proportional to its
//   power A_i sum_c E_ic, with weight w_c = A_i E_ic / p_i, and scores, on landing at k with
//   weight w:
//     collision   w_c rho_kc at every landing;
//     survival    w_c rho_kc / s_k when it survives there (s_k = 0: rho_k = 0, nothing to score);
//     absorption  w_c rho_kc / (1 - s_k) when it is absorbed there.
//   Each has expectation w_c rho_kc per landing, so B_j = E_j + (sum of scores on j) / (A_j M),
//   M the walks so far, is unbiased for the exact-F system's solution.
// Gathering walks (`walks=gathering`) estimate B_i - E_i = sum_m [(diag(rho)F)^m E]_i for the
//   element i they start from: weight w_c = rho_ic, a ray from i lands on y, and the walk scores
//   w_c E_yc by the chosen estimator (collision: at every landing; absorption: / (1 - s_y) when
//   absorbed at y; survival: / s_y when it survives y, or at the landing where s_y = 0 — a black
//   emitter's light has no survival to wait for), then on survival w_c <- w_c rho_yc / s_y and it
//   goes on from y. B_i = E_i + the mean score of i's walks. Walk g (counted over the whole run)
//   starts from element g mod n, so after M walks every element has floor or ceil of M/n; one
//   with none yet shows B = E.
// Steps: `paths` walks per step; the solution is the estimate from every walk so far (each walk
//   independent and unbiased: no bias at all, unlike stochastic-jacobi's averaged iterates; the
//   variance falls as 1/walks). The expectation is the solution of the exact-F system, not of the
//   certified reference's raycast F: they differ by the reference's form-factor error.
// Determinism: walk g draws every number from its own PCG32 stream (seed, g); walks run in
//   parallel (TBB) in blocks and their scores are summed serially in walk order: the same bits on
//   any number of threads, and the three estimators see the very same walks for one seed.
// Work charged: every ray cast with charge_rays and as one element-pair evaluation (a ray samples
//   one pair i -> j), as stochastic-jacobi.
// Left out: continuous walks (from the hit point), bidirectional and next-event estimators,
//   quasi-Monte Carlo numbers (sequence=sobol is stochastic-jacobi's only), importance.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/limits.h"
#include "core/random.h"
#include "core/text.h"
#include "solvers/monte_carlo/element_rays.h"
#include "solvers/monte_carlo/ray_sampler.h"
#include "solvers/solver_factories.h"

namespace radlab {
namespace {

using namespace monte_carlo;

// Rays a block of walks may cast on average: the block is sized from the expected walk length so
// that its scores (one per landing for shooting walks) stay at ~1 MB.
constexpr double kBlockRays = 16384.0;

enum class Estimator { kCollision, kAbsorption, kSurvival };

struct RandomWalkOptions {
  long long paths = 10000;
  std::string walks = "shooting";
  std::string estimator = "collision";
  long long seed = 1;

  static RandomWalkOptions from(ParamBag& bag) {
    RandomWalkOptions o;
    o.paths = bag.get_int("paths", o.paths, 1, kInt64Max);
    o.walks = bag.get_choice("walks", o.walks, {"shooting", "gathering"});
    o.estimator = bag.get_choice("estimator", o.estimator, {"collision", "absorption", "survival"});
    o.seed = bag.get_int("seed", o.seed);
    if (o.seed < 0)
      throw UsageError("random-walk: seed must be >= 0, got " + std::to_string(o.seed));
    // A value given is checked here, before any work; the default (no key: also the registry's
    // reading of the defaults, which must not fail) at init().
    if (bag.has("paths")) o.check_rays_limit();
    return o;
  }

  // Every walk casts one ray at least: the step's rays are at least `paths`.
  void check_rays_limit() const {
    check_limit("rays", double(paths),
                "random-walk: paths=" + std::to_string(paths) +
                    " walks per step (each casts one ray at least)");
  }

  Estimator kind() const {
    if (estimator == "absorption") return Estimator::kAbsorption;
    if (estimator == "survival") return Estimator::kSurvival;
    return Estimator::kCollision;
  }
};

// What one walk leaves: its scores (element, per-channel value) and its rays.
struct Score {
  uint32_t element;
  double value[3];
};
struct WalkRecord {
  std::vector<Score> scores;
  uint64_t rays = 0;
};

class RandomWalkSolver final : public Solver {
 public:
  explicit RandomWalkSolver(RandomWalkOptions options)
      : o_(std::move(options)), estimator_(o_.kind()), shooting_(o_.walks == "shooting") {}

  void init(const System& system) override {
    o_.check_rays_limit();
    system_ = &system;
    const size_t n = system.size();
    channels_ = system.channels();
    const Radiosity& rho = system.reflectance();
    survival_.assign(n, 0.0);
    for (size_t i = 0; i < n; ++i)
      for (int c = 0; c < channels_; ++c) {
        const double r = rho.at(c, i);
        if (!(r < 1.0))
          throw InputError(
              "random-walk: element " + std::to_string(i) + " (polygon " +
              std::to_string(system.mesh().polygon[i]) + ") reflects " + text::format_double(r) +
              (channels_ == 1 ? std::string() : " in channel " + std::to_string(c)) +
              ": walks survive with probability rho, so a walk never ends there (in a closed "
              "room of such elements, never at all) and the absorption estimator's 1/(1 - rho) "
              "is infinite; use reflectances below 1, or stochastic-jacobi, which takes them");
        survival_[i] = std::max(survival_[i], r);
      }
    rays_ = std::make_unique<ElementRays>(system.mesh());
    std::vector<double> power(n, 0.0);
    for (size_t i = 0; i < n; ++i)
      for (int c = 0; c < channels_; ++c)
        power[i] += system.area()[i] * std::abs(system.emission().at(c, i));
    emitters_ = std::make_unique<ElementDistribution>(power);
    sum_ = Radiosity(channels_, n);
    walks_of_.assign(n, 0);
    solution_ = system.emission();
    walks_ = rays_cast_ = 0;
    // Nothing emits, or nothing reflects: B = E is exact (as the deterministic solvers, the run
    // then stops at once, casting no ray).
    done_ = !(emitters_->total() > 0.0) || system.max_reflectance() == 0.0;
    const double longest = 1.0 / (1.0 - system.max_reflectance());  // mean rays of a walk, at most
    walks_per_block_ = size_t(std::clamp(kBlockRays / longest, 64.0, kBlockRays));
  }

  StepInfo step() override {
    if (done_) return {.finished = true};
    const uint64_t paths = uint64_t(o_.paths);
    std::vector<WalkRecord> block(std::min<uint64_t>(walks_per_block_, paths));
    uint64_t cast = 0;
    for (uint64_t first = 0; first < paths; first += block.size()) {
      const size_t count = size_t(std::min<uint64_t>(block.size(), paths - first));
      const uint64_t base = walks_ + first;  // the run-wide index of the block's first walk
      tbb::parallel_for(tbb::blocked_range<size_t>(0, count, 16), [&](const auto& range) {
        for (size_t r = range.begin(); r != range.end(); ++r) {
          WalkRecord& record = block[r];
          record.scores.clear();
          record.rays = 0;
          const uint64_t g = base + r;
          Pcg32 rng(hash_combine(uint64_t(o_.seed), g),
                    hash_combine(uint64_t(o_.seed) ^ 0x3a11c0deu, g));
          if (shooting_)
            shoot(rng, record);
          else
            gather(size_t(g % system_->size()), rng, record);
        }
      });
      // Summed in walk order: the same bits whatever the threads did.
      for (size_t r = 0; r < count; ++r) {
        cast += block[r].rays;
        for (const Score& s : block[r].scores)
          for (int c = 0; c < channels_; ++c) sum_.at(c, s.element) += s.value[c];
        if (!shooting_) ++walks_of_[(base + r) % system_->size()];
      }
    }
    walks_ += paths;
    rays_cast_ += cast;
    system_->charge_rays(cast);
    system_->charge_pair_evaluations(cast);
    update_solution();
    return {};
  }

  const Radiosity& solution() const override { return solution_; }

  std::vector<std::pair<std::string, double>> statistics() const override {
    return {{"walks", double(walks_)},
            {"rays", double(rays_cast_)},
            {"rays_per_walk", walks_ > 0 ? double(rays_cast_) / double(walks_) : 0.0}};
  }

 private:
  // Five numbers for one ray from the walk's stream (u[0] unused by element_rays.h).
  static void draw(Pcg32& rng, double* u) {
    for (int k = 0; k < kDimensions; ++k) u[k] = rng.next_double();
  }

  // One shooting walk: scores of reflected power on the elements it lands on (see the top).
  void shoot(Pcg32& rng, WalkRecord& record) const {
    const Radiosity& rho = system_->reflectance();
    double u[kDimensions];
    draw(rng, u);
    size_t at = emitters_->pick(u[0]);
    double own = 0.0;
    for (int c = 0; c < channels_; ++c) own += std::abs(system_->emission().at(c, at));
    double w[3] = {0.0, 0.0, 0.0};
    // A_i E_ic / p_i with p_i = A_i sum_c |E_ic| / total: the area cancels.
    for (int c = 0; c < channels_; ++c)
      w[c] = system_->emission().at(c, at) * emitters_->total() / own;
    for (;;) {
      draw(rng, u);
      const uint32_t hit = rays_->trace(at, u);
      ++record.rays;
      if (hit == ElementRays::kMiss) return;
      const double s = survival_[hit];
      const bool survives = rng.next_double() < s;
      // s = 0 means rho = 0 at the hit: the score (w rho) is nothing whatever the weight.
      const double factor =
          estimator_weight(s, survives, 0.0);  // the score is w_c rho_kc times this
      if (factor != 0.0) {
        Score score{hit, {0.0, 0.0, 0.0}};
        for (int c = 0; c < channels_; ++c) score.value[c] = w[c] * rho.at(c, hit) * factor;
        record.scores.push_back(score);
      }
      if (!survives) return;
      for (int c = 0; c < channels_; ++c) w[c] *= rho.at(c, hit) / s;
      at = hit;
    }
  }

  // The estimator's weight of a landing on an element the walk survives with probability s:
  // collision scores every landing, survival only those the walk goes on from (1/s), absorption
  // only those it ends at (1/(1 - s)); `at_zero` is the survival estimator's weight where s = 0.
  double estimator_weight(double s, bool survives, double at_zero) const {
    switch (estimator_) {
      case Estimator::kCollision:
        return 1.0;
      case Estimator::kSurvival:
        return s == 0.0 ? at_zero : (survives ? 1.0 / s : 0.0);
      case Estimator::kAbsorption:
        return survives ? 0.0 : 1.0 / (1.0 - s);
    }
    return 0.0;
  }

  // One gathering walk from `start`: one score, the sum of its contributions to B_start - E.
  void gather(size_t start, Pcg32& rng, WalkRecord& record) const {
    const Radiosity& rho = system_->reflectance();
    const Radiosity& E = system_->emission();
    Score total{uint32_t(start), {0.0, 0.0, 0.0}};
    double w[3] = {0.0, 0.0, 0.0};
    for (int c = 0; c < channels_; ++c) w[c] = rho.at(c, start);
    double u[kDimensions];
    size_t at = start;
    // A black element gathers nothing: B = E there, no ray needed.
    if (survival_[start] > 0.0) {
      for (;;) {
        draw(rng, u);
        const uint32_t hit = rays_->trace(at, u);
        ++record.rays;
        if (hit == ElementRays::kMiss) break;
        const double s = survival_[hit];
        const bool survives = rng.next_double() < s;
        // s = 0: the walk ends on an element that reflects nothing; its emission counts once.
        const double factor =
            estimator_weight(s, survives, 1.0);  // the score is w_c E_yc times this
        for (int c = 0; c < channels_; ++c) total.value[c] += w[c] * E.at(c, hit) * factor;
        if (!survives) break;
        for (int c = 0; c < channels_; ++c) w[c] *= rho.at(c, hit) / s;
        at = hit;
      }
    }
    record.scores.push_back(total);
  }

  void update_solution() {
    const System& system = *system_;
    const Radiosity& E = system.emission();
    for (int c = 0; c < channels_; ++c)
      for (size_t j = 0; j < system.size(); ++j) {
        double reflected = 0.0;
        if (shooting_)
          reflected = sum_.at(c, j) / (system.area()[j] * double(walks_));
        else if (walks_of_[j] > 0)
          reflected = sum_.at(c, j) / double(walks_of_[j]);
        solution_.at(c, j) = E.at(c, j) + reflected;
      }
  }

  RandomWalkOptions o_;
  Estimator estimator_;
  bool shooting_;
  const System* system_ = nullptr;
  int channels_ = 1;
  std::unique_ptr<ElementRays> rays_;
  std::unique_ptr<ElementDistribution> emitters_;
  std::vector<double> survival_;
  std::vector<uint64_t> walks_of_;  // gathering: walks started from each element so far
  Radiosity sum_, solution_;
  uint64_t walks_ = 0, rays_cast_ = 0;
  size_t walks_per_block_ = 64;
  bool done_ = false;
};

}  // namespace

SolverInfo random_walk_solver_info() {
  return {"random-walk",
          "discrete random walks with survival by reflectance: shooting from the emitters or "
          "gathering from the elements; collision, absorption or survival estimator; matrix-free",
          "Sbert 1993; Bekaert 1999 (KU Leuven) ch. 5; Sbert, Bekaert & Halton VMV 2001",
          "`paths` walks (one ray per bounce; one ray = one pair evaluation)",
          {{"paths", "", "walks started per step (> 0)"},
           {"walks", "", "shooting (from the emitters, by power) or gathering (from each element)"},
           {"estimator", "", "collision, absorption or survival"},
           {"seed", "", "seed of the walks"}},
          [](ParamBag& bag) -> std::unique_ptr<Solver> {
            return std::make_unique<RandomWalkSolver>(RandomWalkOptions::from(bag));
          },
          SolverKind::kOther,
          /*matrix_free=*/true};
}

}  // namespace radlab
