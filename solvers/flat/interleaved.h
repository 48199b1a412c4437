// The interleaved solver (Wu & Wang 2002), declared here so that tests and experiments can look
// inside it: which element the last step shot or gathered at, the outstanding pre-received
// radiosity, and the per-session coverage of the paper's Figs. 2 and 4. interleaved.cpp has the
// method, the bookkeeping and its proof.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "core/param_bag.h"
#include "solvers/flat/paired_gather.h"
#include "solvers/flat/shooting_core.h"
#include "solvers/solver.h"

namespace radlab {

struct InterleavedOptions {
  long long shots = 400;        // shots per shooting session (Wu & Wang's examples: 400-800)
  long long gathers = 400;      // gathers per gathering session; 0 = sorted shooting that only
                                // records the coverage (for the paper's Figs. 2 and 4)
  long long max_sessions = 32;  // gathering sessions whose pre-receipts are tracked source by
                                // source (memory: one snapshot of B each); beyond it the oldest
                                // session's outstanding pre-receipts are handed back

  static InterleavedOptions from(ParamBag& bag);
  void validate() const;
};

class InterleavedSolver final : public Solver {
 public:
  explicit InterleavedSolver(InterleavedOptions options) : options_(options) {}

  void init(const System& system) override;
  StepInfo step() override;
  const Radiosity& solution() const override { return core_.solution(); }
  const Radiosity* unshot() const override { return &core_.unshot(); }
  const ShotCoverage* shot_coverage() const override { return &coverage_; }

  // Introspection (tests, experiments).
  struct Action {
    bool gather = false;  // false: a shot
    size_t element = kernels::kNone;
  };
  const Action& last_action() const { return last_action_; }
  // a_c,r: radiosity element r has received in advance by gathering and that its sources have
  // not shot yet. Exactly: residual(B - dB) = dB - a (DESIGN §2's invariant with a = 0 when no
  // gather is outstanding).
  const Radiosity& advance() const { return advance_; }
  // x = B - dB: what each element has shot.
  const Radiosity& shot() const { return core_.shot(); }
  // Gathering sessions whose pre-receipts are still tracked.
  size_t live_sessions() const { return sessions_.size(); }

 private:
  struct Session {
    long long id = 0;
    Radiosity snapshot;           // B at the start of the gathering session
    std::vector<size_t> members;  // elements whose latest gather was in this session
  };

  void shoot_step();
  // Prefetches what correcting member r reads (shoot_step), kMemberPrefetch members ahead.
  static constexpr size_t kMemberPrefetch = 8;
  template <class Row>
  void prefetch_member(const Row& F, size_t r) const;
  void gather_step();
  void start_gathering();
  void start_shooting();
  void release(size_t session_index);
  int session_of(size_t element) const;

  InterleavedOptions options_;
  ShootingCore core_;
  Radiosity advance_;
  kernels::Argmax best_;
  bool gathering_ = false;
  long long shots_done_ = 0;
  std::vector<size_t> gather_queue_;
  size_t gather_next_ = 0;
  PairedGather pairs_;           // a session's gathers two a pass on a dense matrix
  long long session_count_ = 0;  // shooting sessions started
  std::vector<double> dff_;
  std::vector<uint8_t> shot_in_session_;
  std::vector<long long>
      session_id_;  // per element: id of its latest live gathering session, or -1
  std::vector<std::unique_ptr<Session>> sessions_;  // oldest first
  long long next_session_id_ = 0;
  ShotCoverage coverage_;
  Action last_action_;
};

}  // namespace radlab
