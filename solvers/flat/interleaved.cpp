// interleaved — shooting sessions interleaved with gathering sessions (Wu & Wang 2002).
//
// Method: a shooting session of `shots` sorted shots (largest unshot power A_i sum_c dB_ci first,
//   as sorted-shooting) accumulates, for every receiver j, dff_j += F_ji = F_ij A_i / A_j: how
//   much of j's view the session's shooters covered. Then a gathering session of `gathers`
//   gathers, one per step, at the elements with the smallest dff among those that did not shoot
//   in the session (and that reflect in some channel: a gather cannot change a black element),
//   in increasing dff. dff and the "shot" marks restart with every shooting session.
//
// Gathering without counting energy twice. A gather at r takes in radiosity that other elements
// have received but not yet shot; when they shoot it later, r must not receive it again. The
// paper keeps, per element, its "Gathering No." (the latest session in which it gathered) and
// its unshot radiosity split by session. radlab keeps the same information as one snapshot per
// gathering session k, S(k) = x + max(dB, 0) at the start of the session (S_j(k) - x_j is exactly
// j's unshot radiosity "as of session k" while j has not shot past it), and per element the id
// k_r of its latest gathering session. With y^r_j = max(x_j, S_j(k_r)) (y^r = x if r never
// gathered):
//
//   B_r = E_r + rho_r sum_j F_rj y^r_j                                               (*)
//
// - a gather at r in session k reads row r and sets B_r = E_r + rho_r sum_j F_rj S_j(k) (all
//   gathers of a session read the same snapshot, which is >= x: no shot happens during a
//   gathering session, so y^r becomes S(k)); the change goes into dB_r (r will shoot it) and
//   into a_r, the advance. Without retirement S(k) is also >= every older snapshot and the change
//   is an increase; after a retirement (below) it can be negative where a source's estimate
//   dropped, and r then gives back what it had pre-received beyond the new snapshot;
// - why max(dB, 0): dB_j < 0 only after a retirement handed back an advance that j had already
//   shot (j then owes; it has nothing unshot to gather). Snapshotting B_j = x_j + dB_j < x_j
//   would make a gather un-receive x_j - B_j that j's shots had already delivered, energy that no
//   later shot of j would bring back (tests/solvers/flat/gathering_test.cpp's brute-force model
//   caught this with max_sessions=2);
// - a shot of s from i moves y^r_i from max(x_i, S_i) to max(x_i + s, S_i). The shot delivers s
//   to every receiver in one streaming pass as in plain shooting, then subtracts, for the members
//   of each live session whose snapshot of i is above x_i, the part they had already gathered
//   (no work when i has shot past every live snapshot, the common case).
// So each element's unshot radiosity reaches each receiver exactly once, early (gathered) or
// when shot. With reciprocal form factors (*) holds exactly and B <= B*; until a session is
// retired B never decreases (from B = E, E >= 0). For any F the bookkeeping keeps, exactly up to
// rounding,
//
//   dB - a = E + J' x - x  (the residual of x = B - dB),  a = outstanding advances >= 0,
//
// DESIGN §2's invariant with the advance: a shot pays a_r down by what it does not deliver to r.
// tests/solvers/flat/gathering_test.cpp checks both against the dense matrix and against a
// brute-force model that stores every (receiver, source) pre-receipt. Memory: one snapshot (n x
// channels doubles) per live gathering session. A session dies when
//   all its members gathered again later, or when x has passed its snapshot everywhere (every
//   pre-receipt delivered); beyond max_sessions the oldest is retired early by handing its
//   members' outstanding advances back (dB_r -= a_r, a_r = 0: still exact, but those elements'
//   estimates drop until the energy arrives by shooting).
// Paper: Wu & Wang 2002, "Interleaving Radiosity", §3 (pseudo-code lines 5-25) and Figs. 1-4.
// Parameters: shots (>= 1), gathers (>= 0; 0 = sorted shooting that records dff), max_sessions
//   (>= 1); defaults: `radlab solvers` (InterleavedOptions).
// Cost per step: one form-factor row (a shot or a gather; on a dense matrix two gathers of a
//   session share one pass over its snapshot, paired_gather.h, each charged at its own step, the
//   same bits). A shot whose shooter has unshot
//   radiosity that some session already gathered adds one multiply-add per member of that
//   session; a session change costs O(n log n) without rows (sorting by dff, a snapshot, a scan).
// Left out: gathers that see the radiosity gathered earlier in the same session (all gathers of
//   a session read the session's snapshot, so they are order-independent and exact).
#include "solvers/flat/interleaved.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <type_traits>

#include "core/error.h"
#include "solvers/solver_factories.h"

namespace radlab {

InterleavedOptions InterleavedOptions::from(ParamBag& bag) {
  InterleavedOptions o;
  o.shots = bag.get_int("shots", o.shots);
  o.gathers = bag.get_int("gathers", o.gathers);
  o.max_sessions = bag.get_int("max_sessions", o.max_sessions);
  o.validate();
  return o;
}

void InterleavedOptions::validate() const {
  if (shots < 1)
    throw UsageError("interleaved: shots must be >= 1 (shots per session), got " +
                     std::to_string(shots));
  if (gathers < 0)
    throw UsageError("interleaved: gathers must be >= 0 (0 = shooting only), got " +
                     std::to_string(gathers));
  if (max_sessions < 1)
    throw UsageError("interleaved: max_sessions must be >= 1, got " + std::to_string(max_sessions));
}

void InterleavedSolver::init(const System& system) {
  if (system.two_level())
    throw UsageError(
        "interleaved: Wu & Wang's coverage is defined for element shooters; run it "
        "without patches");
  core_.init(system);
  const size_t n = system.size();
  advance_ = Radiosity(system.channels(), n);
  dff_.assign(n, 0.0);
  shot_in_session_.assign(n, 0);
  session_id_.assign(n, -1);
  sessions_.clear();
  next_session_id_ = 0;
  gather_queue_.clear();
  gather_next_ = 0;
  pairs_.reset();
  session_count_ = 0;
  last_action_ = {};
  start_shooting();
}

void InterleavedSolver::start_shooting() {
  // The session just gathered keeps its members in index order (see shoot_step); removals from
  // older sessions keep theirs.
  if (!sessions_.empty()) {
    auto& members = sessions_.back()->members;
    std::sort(members.begin(), members.end());
  }
  gathering_ = false;
  shots_done_ = 0;
  ++session_count_;
  std::fill(dff_.begin(), dff_.end(), 0.0);
  std::fill(shot_in_session_.begin(), shot_in_session_.end(), uint8_t{0});
  best_ = core_.max_priority();
  coverage_ = {dff_, shot_in_session_, session_count_};
}

StepInfo InterleavedSolver::step() {
  if (gathering_) {
    gather_step();
    return {};
  }
  if (!(best_.value > 0.0)) {
    if (core_.all_shot()) return {.finished = true};
    best_ = core_.first_unshot();
  }
  shoot_step();
  return {};
}

int InterleavedSolver::session_of(size_t element) const {
  const long long id = session_id_[element];
  if (id < 0) return -1;
  for (size_t q = 0; q < sessions_.size(); ++q)
    if (sessions_[q]->id == id) return int(q);
  return -1;
}

// Members of a session are scattered over the elements (every ~17th on the benchmark's 7,000
// elements with 400 gathers a session), so each correction waits for its own cache misses in
// the row and in six per-element arrays; asking for the member kMemberPrefetch places ahead
// overlaps them. A sparse row's entry is found by a search, not prefetched.
template <class Row>
void InterleavedSolver::prefetch_member(const Row& F, size_t r) const {
  if constexpr (std::is_pointer_v<Row>) __builtin_prefetch(F + r);
  const System& system = core_.system();
  __builtin_prefetch(system.inverse_area().data() + r);
  __builtin_prefetch(system.area().data() + r);
  for (int c = 0; c < core_.channels(); ++c) {
    __builtin_prefetch(core_.unshot().channel(c).data() + r);
    __builtin_prefetch(system.reflectance().channel(c).data() + r);
    __builtin_prefetch(advance_.channel(c).data() + r);
  }
}

void InterleavedSolver::shoot_step() {
  const size_t i = best_.index;
  const int channels = core_.channels();
  double s[3] = {0.0, 0.0, 0.0};
  for (int c = 0; c < channels; ++c) s[c] = core_.unshot().at(c, i);

  // Per live session, the part e of this shot its members gathered already: y^r_i moves by
  // max(x_new, S_i) - max(x_old, S_i) = s - e.
  struct Excess {
    const Session* session;
    double e[3];
  };
  std::vector<Excess> excess;
  for (const auto& q : sessions_) {
    Excess ex{q.get(), {0.0, 0.0, 0.0}};
    bool any = false;
    for (int c = 0; c < channels; ++c) {
      const double x_old = core_.shot().at(c, i);
      const double x_new = x_old + s[c];
      const double S = q->snapshot.at(c, i);
      if (x_old >= S && x_new >= S) continue;      // nothing of i's outstanding for this session
      ex.e[c] = (x_old <= S && x_new <= S) ? s[c]  // all of the shot was gathered in advance
                                           : s[c] - (std::max(x_new, S) - std::max(x_old, S));
      any |= ex.e[c] != 0.0;
    }
    if (any) excess.push_back(ex);
  }

  const System& system = core_.system();
  const double Ai = system.area()[i];
  const double* inverse_area = system.inverse_area().data();
  const Radiosity& rho = system.reflectance();
  core_.system().with_compact_row(i, [&](const auto& F) {
    best_ = core_.shoot(F, i, s, true, dff_.data());
    // One pass over the members: correct each (an element is a member of one session only, so
    // its value is then final) and see whether it now leads (only if a correction was negative).
    // Members are in index order (start_shooting sorts them), so the pass walks the arrays
    // forward; each member's correction is its own, so the order changes no bits.
    const size_t leader = best_.index;
    bool rescan = false;
    kernels::Argmax lead = best_;
    for (const Excess& ex : excess) {
      double w[3] = {0.0, 0.0, 0.0};  // A_i e_c, the same product for every member
      for (int c = 0; c < channels; ++c) w[c] = Ai * ex.e[c];
      const std::vector<size_t>& members = ex.session->members;
      for (size_t k = 0; k < members.size(); ++k) {
        if (k + kMemberPrefetch < members.size()) prefetch_member(F, members[k + kMemberPrefetch]);
        const size_t r = members[k];
        const double g = double(F[r]) * inverse_area[r];
        double minus[3] = {0.0, 0.0, 0.0};
        for (int c = 0; c < channels; ++c) {
          // The kernels' arithmetic (kernels.h): (F_ir / A_r) (A_i e_c rho_cr).
          const double undelivered = g * (w[c] * rho.at(c, r));
          minus[c] = -undelivered;
          advance_.at(c, r) -= undelivered;
        }
        rescan |= r == leader;
        const double p = core_.add_unshot_priority(r, minus);
        if (p > lead.value || (p == lead.value && r < lead.index)) lead = {p, r};
      }
    }
    // If the maximum itself was corrected, any element may lead now.
    best_ = rescan ? core_.max_priority() : lead;
  });
  shot_in_session_[i] = 1;
  last_action_ = {false, i};
  if (++shots_done_ >= options_.shots && options_.gathers > 0) start_gathering();
}

void InterleavedSolver::release(size_t index) {
  const Session& q = *sessions_[index];
  for (size_t r : q.members) {
    for (int c = 0; c < core_.channels(); ++c) {
      core_.add_unshot(c, r, -advance_.at(c, r));
      advance_.at(c, r) = 0.0;
    }
    session_id_[r] = -1;
  }
  sessions_.erase(sessions_.begin() + std::ptrdiff_t(index));
}

void InterleavedSolver::start_gathering() {
  const size_t n = core_.size();
  const int channels = core_.channels();
  // Sessions whose snapshot every element has shot past have delivered all their pre-receipts.
  for (size_t q = sessions_.size(); q-- > 0;) {
    const auto x = core_.shot().raw();
    const auto S = sessions_[q]->snapshot.raw();
    bool passed = true;
    for (size_t k = 0; k < x.size() && passed; ++k) passed = x[k] >= S[k];
    if (passed) release(q);
  }

  std::vector<size_t> candidates;
  const Radiosity& rho = core_.system().reflectance();
  for (size_t j = 0; j < n; ++j) {
    if (shot_in_session_[j]) continue;
    bool reflects = false;
    for (int c = 0; c < channels; ++c) reflects |= rho.at(c, j) > 0.0;
    if (reflects) candidates.push_back(j);
  }
  const size_t count = std::min(candidates.size(), size_t(options_.gathers));
  if (count == 0) {
    start_shooting();
    return;
  }
  std::partial_sort(
      candidates.begin(), candidates.begin() + std::ptrdiff_t(count), candidates.end(),
      [&](size_t a, size_t b) { return dff_[a] < dff_[b] || (dff_[a] == dff_[b] && a < b); });
  candidates.resize(count);

  while (sessions_.size() >= size_t(options_.max_sessions)) release(0);
  auto session = std::make_unique<Session>();
  session->id = next_session_id_++;
  // S = x + max(dB, 0) (see the doc block): = B except where a retirement left dB < 0.
  session->snapshot = core_.shot();
  {
    const auto S = session->snapshot.raw();
    const auto dB = core_.unshot().raw();
    for (size_t k = 0; k < S.size(); ++k) S[k] += std::max(dB[k], 0.0);
  }
  sessions_.push_back(std::move(session));
  gather_queue_ = std::move(candidates);
  gather_next_ = 0;
  gathering_ = true;
}

void InterleavedSolver::gather_step() {
  const size_t r = gather_queue_[gather_next_++];
  Session& q = *sessions_.back();
  const int channels = core_.channels();
  const System& system = core_.system();
  double gathered[3] = {0.0, 0.0, 0.0};
  // A session's gathers all read its snapshot: two a pass on a dense matrix.
  const bool more = gather_next_ < gather_queue_.size();
  pairs_.gather(system, r, more ? std::optional<size_t>(gather_queue_[gather_next_]) : std::nullopt,
                q.snapshot, gathered);
  for (int c = 0; c < channels; ++c) {
    const double B_new = system.emission().at(c, r) + system.reflectance().at(c, r) * gathered[c];
    const double B_old = core_.shot().at(c, r) + core_.unshot().at(c, r);
    const double increase = B_new - B_old;
    core_.add_unshot(c, r, increase);
    advance_.at(c, r) += increase;
  }
  // r's latest gather is now in this session.
  const int previous = session_of(r);
  if (previous >= 0 && sessions_[size_t(previous)].get() != &q) {
    auto& members = sessions_[size_t(previous)]->members;
    members.erase(std::find(members.begin(), members.end(), r));
    if (members.empty()) sessions_.erase(sessions_.begin() + previous);
  }
  if (session_id_[r] != q.id) q.members.push_back(r);
  session_id_[r] = q.id;
  last_action_ = {true, r};
  if (gather_next_ == gather_queue_.size()) start_shooting();
}

SolverInfo interleaved_solver_info() {
  return {"interleaved",
          "shooting sessions (sorted, tracking dff) interleaved with gathering sessions at the "
          "least-covered elements; exact bookkeeping",
          "Wu & Wang 2002 'Interleaving Radiosity'",
          "one form-factor row (a shot or a gather)",
          {{"shots", "", "shots per shooting session"},
           {"gathers", "", "gathers per gathering session (0: shooting only)"},
           {"max_sessions", "", "gathering sessions tracked source by source (memory)"}},
          [](ParamBag& bag) -> std::unique_ptr<Solver> {
            return std::make_unique<InterleavedSolver>(InterleavedOptions::from(bag));
          },
          SolverKind::kShooting};
}

}  // namespace radlab
