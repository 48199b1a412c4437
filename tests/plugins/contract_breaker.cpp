// Solvers that break the Solver contract on purpose, for the runner's checks at the interface
// (tests/experiments/run/solver_contract_test.cpp): radlab must fail the one run, with a message
// naming the solver, and go on with the others; never read out of bounds or end as an internal
// error.
//   contract-ok          Gauss–Seidel, one row per step: a correct plugin solver (its run.json
//                        records this file and its SHA-256)
//   contract-wrong-size  the same, but solution() has one element fewer than the system
//   contract-throws      the same, but its third step throws std::runtime_error
#include <memory>
#include <stdexcept>

#include "solvers/plugin.h"

namespace {

using radlab::ParamBag;
using radlab::Radiosity;
using radlab::StepInfo;
using radlab::System;

enum class Fault { kNone, kWrongSize, kThrows };

class ContractSolver final : public radlab::Solver {
 public:
  explicit ContractSolver(Fault fault) : fault_(fault) {}

  void init(const System& system) override {
    system_ = &system;
    B_ = system.emission();
    if (fault_ == Fault::kWrongSize) shown_ = Radiosity(B_.channels(), B_.size() - 1);
  }

  StepInfo step() override {
    if (fault_ == Fault::kThrows && ++steps_ == 3)
      throw std::runtime_error("contract-throws: deliberate failure at step 3");
    // Gauss–Seidel at element i: B_i = E_i + rho_i sum_j F_ij B_j.
    const System& s = *system_;
    const size_t i = next_;
    next_ = (next_ + 1) % s.size();
    for (int c = 0; c < B_.channels(); ++c) {
      double gathered = 0.0;
      s.with_row(i, [&](const auto* F) {
        for (size_t j = 0; j < s.size(); ++j) gathered += double(F[j]) * B_.at(c, j);
      });
      B_.at(c, i) = s.emission().at(c, i) + s.reflectance().at(c, i) * gathered;
    }
    return {};
  }

  const Radiosity& solution() const override { return fault_ == Fault::kWrongSize ? shown_ : B_; }

 private:
  Fault fault_;
  const System* system_ = nullptr;
  Radiosity B_, shown_;
  size_t next_ = 0;
  int steps_ = 0;
};

radlab::SolverInfo contract_info(const char* name, const char* summary, Fault fault) {
  radlab::SolverInfo info;
  info.name = name;
  info.summary = summary;
  info.reference = "test fixture";
  info.cost = "one form-factor row";
  info.make = [fault](ParamBag&) -> std::unique_ptr<radlab::Solver> {
    return std::make_unique<ContractSolver>(fault);
  };
  info.kind = radlab::SolverKind::kGathering;
  return info;
}

void register_contract_breakers() {
  radlab::register_solver(
      contract_info("contract-ok", "test: a correct plugin solver", Fault::kNone));
  radlab::register_solver(contract_info("contract-wrong-size", "test: solution() one element short",
                                        Fault::kWrongSize));
  radlab::register_solver(
      contract_info("contract-throws", "test: throws std::runtime_error", Fault::kThrows));
}

}  // namespace

RADLAB_PLUGIN(register_contract_breakers)
