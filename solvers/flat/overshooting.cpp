// overshooting — progressive shooting that also shoots an estimate of the energy still to come.
//
// Method: pick an element (below), shoot s = dB_i + o_i and leave dB_i = -o_i (plus its self
//   term): the element pre-shoots radiosity
//   o_i it expects to receive later, and its unshot value may go negative; later arrivals pay it
//   back. The bookkeeping is the plain shot of an arbitrary amount
//   (solvers/flat/shooting_core.h), so dB stays exactly the residual of x = B - dB whatever
//   o_i is, and B = x + dB = E + J x. Variants (per channel c):
//   - ambient (Feda & Purgathofer 1992 as Wu & Wang 2002 describe it: "the area-weighted average
//     unshot radiosity increased by the geometric series of the area-weighted average
//     reflectivity"): o_ci = rho_ci R_c sum_j A_j dB_cj / sum_j A_j with R_c = 1/(1 - rho_avg,c),
//     i.e. the element's reflection of Cohen's ambient (eq. 12-13) computed from the unshot
//     radiosity before the shot.
//   - regather (Gortler, Cohen & Slusallek 1994): o_ci = rho_ci sum_j F_ij dB_cj, what i would
//     gather now from everyone's unshot radiosity. It needs row i before the shot; it is the same
//     row, so one row per step.
//   On a two-level System (solvers/two_level/patches.h) the shooters are patches: dB_i, rho_i and
//   A_i are the patch's area-weighted means and area, and regather reads the patch row P_i.
//   clamp=true counts only positive dB_cj in either estimate (so o_i >= 0): the overshoot never
//   takes back energy that was over-shot elsewhere. That is not steadier: the negative unshot
//   radiosity the overshoots leave is never counted against the next estimate, so with the
//   ambient variant's R = 1/(1 - rho_avg) (100 at rho 0.99) each round over-shoots more than the
//   last; on the closed cube at rho 0.99 it diverges within 40 steps (the runner stops it, exit 4),
//   while clamp=false converges (issue 35.5).
//   Selection: the largest |A_i (dB_i + o_i)| summed over channels, the power the shot would
//   carry: by |A_i dB_i| an element that has just over-shot is picked again to shoot dB + o ~ 0
//   and the solver stalls (seen on the cube with ambient: the error stayed at 0.97; on the
//   Cornell box with regather: it froze at 1e-2). Regather cannot know o_i without the row, so
//   it uses each element's overshoot from its last shot (0 before its first), and finds the
//   maximum inside the shot's pass (the shooter's new o_i is set before its shot).
// Paper: Feda & Purgathofer 1992 and Gortler et al. 1994, as summarised by Wu & Wang 2002 §2.
// Parameters: variant (ambient | regather), clamp (bool), storage (double | float: float rounds
//   x and dB to float after every shot, the accumulation of a float implementation;
//   ShootingCore::set_float_storage); defaults: `radlab solvers` (OvershootingOptions).
// Cost per step: one form-factor row; the ambient variant adds two passes over dB in memory (the
//   unshot power, then the selection: its offset changes for every element at every shot), the
//   regather variant a gather over the same row (two passes over the row, the second from cache).
//   Regather's selection is fused into the shot's pass (kernels::shoot with offsets o), which
//   reads o alongside dB.
// Left out: Feda & Purgathofer's treatment of the overshoot of light sources; the solver stops
//   only when every dB is exactly zero, which overshooting rarely reaches (the runner's budget
//   or tolerance ends the run).
#include <cmath>

#include "core/error.h"
#include "solvers/flat/shooting_core.h"
#include "solvers/solver_factories.h"

namespace radlab {
namespace {

struct OvershootingOptions {
  std::string variant = "regather";  // how o_i is estimated: "ambient" (no extra work per
                                     // entry, a crude global guess) or "regather" (exact first
                                     // bounce of the current unshot energy, per element)
  bool clamp = false;          // count only positive unshot radiosity in o_i (never take back an
                               // overshoot): diverges with ambient at rho >= 0.99, see above
  bool float_storage = false;  // storage=float: x and dB kept in float (Wu & Wang's baseline)

  static OvershootingOptions from(ParamBag& bag) {
    OvershootingOptions o;
    o.variant = bag.get_choice("variant", o.variant, {"ambient", "regather"});
    o.clamp = bag.get_bool("clamp", o.clamp);
    o.float_storage = bag.get_choice("storage", "double", {"double", "float"}) == "float";
    o.validate();
    return o;
  }
  void validate() const {
    if (variant != "ambient" && variant != "regather")
      throw UsageError("overshooting: variant must be ambient or regather, got '" + variant + "'");
  }
};

class OvershootingSolver final : public Solver {
 public:
  explicit OvershootingSolver(OvershootingOptions options)
      : options_(std::move(options)), regather_(options_.variant == "regather") {}

  void init(const System& system) override {
    core_.init(system);
    core_.set_float_storage(options_.float_storage);
    interreflection_.clear();
    overshoot_ = Radiosity(system.channels(), system.shooters().size());
    // Regather: the core's priorities are A_j sum_c |dB_cj + o_cj|, so each shot returns the
    // next shooter (all o = 0 here, the same bits as A_j sum_c |dB_cj|).
    if (regather_) core_.set_priority_offset(&overshoot_);
    best_ = core_.max_priority();
    if (!regather_) {
      for (double rho : average_reflectance(system)) {
        if (!(rho < 1.0))
          throw NumericalError(
              "overshooting: variant=ambient needs an average reflectance below 1, got "
              "rho_avg = " +
              std::to_string(rho));
        interreflection_.push_back(1.0 / (1.0 - rho));
      }
    }
  }

  StepInfo step() override {
    const int channels = core_.channels();
    double s[3] = {0.0, 0.0, 0.0};
    if (!regather_) {
      // Select by the power the shot would carry, A_j sum_c |dB_cj + rho_cj Ambient_c|: by
      // |A_j dB_j| alone, an element that has just over-shot keeps the largest |dB| = o and is
      // picked again and again to shoot dB + o ~ 0 (on the cube at rho 0.9 the error stayed at
      // 0.97 for ever). The ambient changes with every shot, so this is a scan over dB.
      double power[3] = {0.0, 0.0, 0.0};
      core_.unshot_power(options_.clamp, power);
      const std::vector<double> ambient =
          ambient_radiosity(interreflection_, power, core_.system().total_area());
      best_ = {};
      for (size_t j = 0; j < core_.shooters(); ++j) {
        double p = 0.0;
        for (int c = 0; c < channels; ++c)
          p += std::fabs(core_.shooter_unshot(c, j) +
                         core_.shooter_reflectance(c, j) * ambient[size_t(c)]);
        p *= core_.shooter_area(j);
        if (p > best_.value) best_ = {p, j};
      }
      if (!(best_.value > 0.0)) {
        if (core_.all_shot()) return {.finished = true};
        best_ = core_.first_unshot();
      }
      const size_t i = best_.index;
      for (int c = 0; c < channels; ++c)
        s[c] = core_.shooter_unshot(c, i) + core_.shooter_reflectance(c, i) * ambient[size_t(c)];
      core_.system().with_compact_shooter_row(i,
                                              [&](const auto& F) { core_.shoot(F, i, s, false); });
      return {};
    }
    // Regather: select by the power the shot would carry if each element's last overshoot
    // estimate still held, A_j sum_c |dB_cj + o_cj| (o_j = 0 before j's first shot). Selecting by
    // |A_j dB_j| alone re-picks the element that has just over-shot (its dB = -o is the largest)
    // to shoot dB + o ~ 0, over and over: on the Cornell box the error froze at 1e-2. best_ is
    // that maximum, found by the last shot's own pass (o_i was set before it) or at init: the
    // same value and lowest index as a scan over dB, o and A now.
    if (!(best_.value > 0.0)) {
      if (core_.all_shot()) return {.finished = true};
      best_ = core_.first_unshot();
    }
    const size_t i = best_.index;
    for (int c = 0; c < channels; ++c) s[c] = core_.shooter_unshot(c, i);
    core_.system().with_compact_shooter_row(i, [&](const auto& F) {
      double gathered[3] = {0.0, 0.0, 0.0};
      kernels::gather(F, core_.unshot(), gathered, options_.clamp);
      for (int c = 0; c < channels; ++c) {
        overshoot_.at(c, i) = core_.shooter_reflectance(c, i) * gathered[c];
        s[c] += overshoot_.at(c, i);
      }
      best_ = core_.shoot(F, i, s, true);
    });
    return {};
  }

  const Radiosity& solution() const override { return core_.solution(); }
  const Radiosity* unshot() const override { return &core_.unshot(); }

 private:
  OvershootingOptions options_;
  bool regather_;
  ShootingCore core_;
  kernels::Argmax best_;
  std::vector<double> interreflection_;  // R_c (ambient variant)
  Radiosity overshoot_;                  // o_j of each element's last shot (regather variant)
};

}  // namespace

SolverInfo overshooting_solver_info() {
  return {"overshooting",
          "progressive shooting of dB_i + o_i, leaving dB_i = -o_i (unshot may go negative)",
          "Feda & Purgathofer 1992; Gortler et al. 1994 (as in Wu & Wang 2002 §2)",
          "one form-factor row",
          {{"variant", "",
            "overshoot estimate: ambient (rho_i R avg unshot) or regather (rho_i sum F_ij dB_j)"},
           {"clamp", "",
            "count only positive unshot radiosity in the estimate (never takes an overshoot back: "
            "with variant=ambient it diverges at rho >= 0.99)"},
           {"storage", "", "double or float: keep x and dB in float (Wu & Wang's baseline)"}},
          [](ParamBag& bag) -> std::unique_ptr<Solver> {
            return std::make_unique<OvershootingSolver>(OvershootingOptions::from(bag));
          },
          SolverKind::kShooting};
}

}  // namespace radlab
