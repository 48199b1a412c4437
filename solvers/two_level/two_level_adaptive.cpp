// adaptive-shooting — Cohen et al. 1988 §3.4 and §4 in full: sorted patch shooting to elements
// that split where the radiosity changes sharply.
//
// Method: runs on a two-level System (solvers/two_level/patches.h) whose mesh is the *evaluation
// mesh*, the
//   finest subdivision allowed (on a one-level System every patch is one element, nothing can
//   split, and this is sorted shooting). The solver's own elements are blocks of those fine
//   elements inside one patch, starting from each patch split `levels` times (each split halves a
//   block along both in-plane axes of its polygon; a block of one fine element cannot split). Each
//   step shoots the patch p with the largest unshot power A_p sum_c |dB_cp| (Southwell, as
//   sorted-shooting): the patch row P_p, read once, is summed over each block b's fine elements
//   (P_pb = sum_{e in b} P_pe, exactly what a hemi-cube sees of the union) and delivers delta_b =
//   rho_b P_pb (A_p/A_b) dB_p to B_b and dB_b; the patch's own blocks are then emptied. Then, as
//   the paper's pseudo-code: "interpolate vertex radiosities from neighboring elements; if gradient
//   from neighboring vertices is too high, subdivide elements and reshoot patch i": vertex
//   radiosities are the area-weighted means of the adjacent fine elements (each holding its block's
//   value, mean of the channels), and a block splits when the vertex radiosities on it differ by
//   more than threshold * Bbar, Bbar the area-weighted mean reflected radiosity B - E over the
//   reflecting elements (so the test is scale-free and ignores emission). A split block's children
//   inherit its B and dB minus this shot's delta_b, plus their own share of the shot (the patch
//   re-shot to them); sum_c A_c delta_c = A_b delta_b, so a split conserves A B and A dB (to
//   rounding). Splitting repeats until no block exceeds the threshold or every offender is one fine
//   element.
// Measurement: solution() projects the blocks onto the evaluation mesh (each fine element shows its
//   block's value), so errors stay comparable while the mesh changes; solver_elements() is the
//   number of blocks (trace.csv marks every mesh change). The run's reference is that of the
//   fine two-level system (the finest allowed subdivision); run.json adds the certified reference
//   of the final blocks' system and the distances to it (adaptive_blocks() gives the blocks;
//   experiments/problem/two_level_problem.h, docs/solvers.md say why the trace keeps the fine
//   one). The adaptive estimate is not the solution of any one linear system: light received before
//   a block split stays spread evenly over its children (only the current shot is re-shot to them),
//   so it approaches the fine solution only where it subdivided before the light arrived; with
//   levels deep enough that every block is one fine element it is sorted patch shooting on the fine
//   system and reaches its reference (tested). The trace's floor is that discretisation error.
// Paper: Cohen, Chen, Wallace & Greenberg 1988 §3.4, §4 (adaptive subdivision, ambient display).
// Parameters: threshold (> 0), levels (initial splits per patch), ambient (display-only ambient
//   term, as sorted-shooting); defaults: `radlab solvers` (AdaptiveOptions).
// Cost per step: one patch row (counted as one row and as many pair evaluations as there are
//   blocks, the elements the paper projects onto the hemi-cube); a re-shoot after splits charges
//   the children as pair evaluations but no row (the row is kept, as a stored item buffer is);
//   each subdivision pass forms vertex values over the evaluation mesh (O(n)).
// Left out: subdividing patches (the paper: rarely needed), T-junction handling in the display
//   (the images show the evaluation mesh, each fine element its block's value).
#include "solvers/two_level/two_level_adaptive.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>

#include "core/error.h"
#include "core/text.h"
#include "solvers/flat/shooting_core.h"
#include "solvers/solver_factories.h"

namespace radlab {
namespace {

struct AdaptiveOptions {
  double threshold = 0.5;  // split where vertex radiosities differ by more than this times the
                           // mean reflected radiosity: smaller splits more (down to the fine mesh)
  int levels = 1;          // initial splits of every patch (0: each patch one element)
  bool ambient = false;    // Cohen's display-only ambient term

  static AdaptiveOptions from(ParamBag& bag) {
    AdaptiveOptions o;
    o.threshold = bag.get_double("threshold", o.threshold);
    o.levels = int(bag.get_int("levels", o.levels));
    o.ambient = bag.get_bool("ambient", o.ambient);
    o.validate();
    return o;
  }
  void validate() const {
    if (!(threshold > 0.0 && std::isfinite(threshold)))
      throw UsageError("adaptive-shooting: threshold must be a finite number > 0, got " +
                       text::format_double(threshold));
    if (levels < 0 || levels > 20)
      throw UsageError("adaptive-shooting: levels must lie in [0,20], got " +
                       std::to_string(levels));
  }
};

class AdaptiveShootingSolver final : public Solver {
 public:
  explicit AdaptiveShootingSolver(AdaptiveOptions options) : options_(options) {}

  void init(const System& system) override {
    system_ = &system;
    const Mesh& mesh = system.mesh();
    const Patches& patches = system.shooters();
    C_ = system.channels();
    blocks_.clear();
    block_of_.assign(mesh.size(), 0);
    for (int c = 0; c < C_; ++c) {
      B_[c].clear();
      dB_[c].clear();
      delta_[c].clear();
    }
    for (size_t p = 0; p < patches.size(); ++p) {
      Block b;
      b.patch = uint32_t(p);
      b.fine.assign(patches.members(p).begin(), patches.members(p).end());
      add_block(std::move(b));
    }
    for (int level = 0; level < options_.levels; ++level) {
      const size_t count = blocks_.size();
      for (size_t b = 0; b < count; ++b) split(b, nullptr);
    }
    interreflection_.clear();
    if (options_.ambient)
      for (double rho : average_reflectance(system)) {
        if (!(rho < 1.0))
          throw NumericalError(
              "adaptive-shooting: ambient=true needs an average reflectance below 1, got " +
              text::format_double(rho));
        interreflection_.push_back(1.0 / (1.0 - rho));
      }
    row_.assign(mesh.size(), 0.0);
    dirty_ = true;
  }

  StepInfo step() override {
    const Patches& patches = system_->shooters();
    // The patch with the largest unshot power (ties to the lowest index).
    std::vector<double> power(patches.size() * size_t(C_), 0.0);
    for (size_t b = 0; b < blocks_.size(); ++b)
      for (int c = 0; c < C_; ++c)
        power[blocks_[b].patch * size_t(C_) + size_t(c)] += blocks_[b].area * dB_[c][b];
    size_t p = patches.size();
    double best = 0.0;
    for (size_t q = 0; q < patches.size(); ++q) {
      double v = 0.0;
      for (int c = 0; c < C_; ++c) v += std::fabs(power[q * size_t(C_) + size_t(c)]);
      if (v > best) {
        best = v;
        p = q;
      }
    }
    if (p == patches.size()) return {.finished = true};
    const double Ap = patches.area(p);
    for (int c = 0; c < C_; ++c) shot_[c] = power[p * size_t(C_) + size_t(c)] / Ap;

    system_->with_shooter_row(p, blocks_.size(), [&](const auto* F) {
      for (size_t e = 0; e < row_.size(); ++e) row_[e] = double(F[e]);
    });
    for (int c = 0; c < C_; ++c) std::fill(delta_[c].begin(), delta_[c].end(), 0.0);
    std::vector<double> before[3];
    for (int c = 0; c < C_; ++c) before[c] = dB_[c];
    for (size_t b = 0; b < blocks_.size(); ++b) deliver(b, Ap);
    for (size_t b = 0; b < blocks_.size(); ++b)
      if (blocks_[b].patch == p)
        for (int c = 0; c < C_; ++c) dB_[c][b] -= before[c][b];
    if (system_->two_level()) subdivide(Ap);  // one level: every block is one element
    dirty_ = true;
    return {};
  }

  const Radiosity& solution() const override {
    refresh();
    return fine_B_;
  }
  const Radiosity* unshot() const override {
    refresh();
    return &fine_dB_;
  }
  size_t solver_elements() const override { return blocks_.size(); }
  const std::vector<uint32_t>& block_of() const { return block_of_; }

  Radiosity display() const override {
    Radiosity shown = solution();
    if (!options_.ambient) return shown;
    double power[3] = {0.0, 0.0, 0.0};
    for (size_t b = 0; b < blocks_.size(); ++b)
      for (int c = 0; c < C_; ++c) power[c] += blocks_[b].area * dB_[c][b];
    const std::vector<double> ambient =
        ambient_radiosity(interreflection_, power, system_->total_area());
    for (int c = 0; c < C_; ++c)
      for (size_t e = 0; e < shown.size(); ++e)
        shown.at(c, e) += system_->reflectance().at(c, e) * ambient[size_t(c)];
    return shown;
  }

 private:
  struct Block {
    uint32_t patch = 0;
    std::vector<uint32_t> fine;  // the evaluation-mesh elements it covers
    double area = 0.0;
    double rho[3] = {0.0, 0.0, 0.0};
  };

  // Appends b with B = dB = its area-weighted emission.
  void add_block(Block b) {
    const System& s = *system_;
    b.area = 0.0;
    double E[3] = {0.0, 0.0, 0.0};
    for (uint32_t e : b.fine) {
      b.area += s.area()[e];
      for (int c = 0; c < C_; ++c) {
        b.rho[c] += s.area()[e] * s.reflectance().at(c, e);
        E[c] += s.area()[e] * s.emission().at(c, e);
      }
    }
    for (int c = 0; c < C_; ++c) {
      b.rho[c] /= b.area;
      B_[c].push_back(E[c] / b.area);
      dB_[c].push_back(E[c] / b.area);
      delta_[c].push_back(0.0);
    }
    for (uint32_t e : b.fine) block_of_[e] = uint32_t(blocks_.size());
    blocks_.push_back(std::move(b));
  }

  // This shot's delivery to block b (row_ holds the shooter's row), added to B and dB.
  void deliver(size_t b, double Ap) {
    double P = 0.0;
    for (uint32_t e : blocks_[b].fine) P += row_[e];
    const double g = P * Ap / blocks_[b].area;
    for (int c = 0; c < C_; ++c) {
      const double d = blocks_[b].rho[c] * g * shot_[c];
      delta_[c][b] = d;
      B_[c][b] += d;
      dB_[c][b] += d;
    }
  }

  // Splits block b in up to four along its polygon's in-plane axes. With Ap (during a step), the
  // children inherit b's values without this shot's delta and receive their own (the re-shot).
  // Returns false when b cannot split (one fine element).
  bool split(size_t b, const double* Ap) {
    if (blocks_[b].fine.size() < 2) return false;
    const Mesh& mesh = system_->mesh();
    const Block parent = blocks_[b];
    const uint32_t first = parent.fine.front();
    std::vector<Vec3> corners;
    mesh.corners(first, corners);
    const Vec3 n = mesh.normal[first];
    Vec3 u = corners[1] - corners[0];
    u = glm::normalize(u - glm::dot(u, n) * n);
    const Vec3 v = glm::cross(n, u);
    double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};
    for (uint32_t e : parent.fine) {
      const double x[2] = {glm::dot(mesh.centroid[e], u), glm::dot(mesh.centroid[e], v)};
      for (int k = 0; k < 2; ++k) {
        lo[k] = std::min(lo[k], x[k]);
        hi[k] = std::max(hi[k], x[k]);
      }
    }
    // An axis along which the centroids do not spread (a strip) is not split.
    const double tiny = 1e-9 * std::sqrt(parent.area);
    Block children[4];
    for (uint32_t e : parent.fine) {
      const double x[2] = {glm::dot(mesh.centroid[e], u), glm::dot(mesh.centroid[e], v)};
      int quadrant = 0;
      for (int k = 0; k < 2; ++k)
        if (hi[k] - lo[k] > tiny && x[k] > 0.5 * (lo[k] + hi[k])) quadrant |= 1 << k;
      children[quadrant].fine.push_back(e);
    }
    double value[3], unshot[3];
    for (int c = 0; c < C_; ++c) {
      value[c] = B_[c][b] - (Ap ? delta_[c][b] : 0.0);
      unshot[c] = dB_[c][b] - (Ap ? delta_[c][b] : 0.0);
    }
    bool reused = false;
    for (Block& child : children) {
      if (child.fine.empty()) continue;
      child.patch = parent.patch;
      size_t slot = b;
      if (reused) {
        slot = blocks_.size();
        add_block(std::move(child));
      } else {
        reused = true;
        // The parent's slot takes the first child (its fine elements keep pointing at it).
        child.area = 0.0;
        for (int c = 0; c < 3; ++c) child.rho[c] = parent.rho[c];
        for (uint32_t e : child.fine) child.area += system_->area()[e];
        blocks_[b] = std::move(child);
      }
      for (int c = 0; c < C_; ++c) {
        B_[c][slot] = value[c];
        dB_[c][slot] = unshot[c];
        delta_[c][slot] = 0.0;
      }
      if (Ap) {
        deliver(slot, *Ap);
        system_->charge_pair_evaluations(1);
      }
    }
    return true;
  }

  // Vertex radiosities on the evaluation mesh (mean of channels, area-weighted over the adjacent
  // fine elements, each holding its block's value), then the split test per block, repeated.
  void subdivide(double Ap) {
    const Mesh& mesh = system_->mesh();
    for (;;) {
      // Bbar: the mean reflected radiosity B - E over reflecting blocks.
      double reflected = 0.0, area = 0.0;
      for (size_t b = 0; b < blocks_.size(); ++b) {
        double rho = 0.0, out = 0.0;
        for (int c = 0; c < C_; ++c) {
          rho += blocks_[b].rho[c];
          double E = 0.0;
          for (uint32_t e : blocks_[b].fine) E += system_->area()[e] * system_->emission().at(c, e);
          out += B_[c][b] - E / blocks_[b].area;
        }
        if (rho > 0.0) {
          reflected += blocks_[b].area * out / C_;
          area += blocks_[b].area;
        }
      }
      if (!(area > 0.0 && reflected > 0.0)) return;
      const double limit = options_.threshold * reflected / area;
      vertex_sum_.assign(mesh.vertices.size(), 0.0);
      vertex_weight_.assign(mesh.vertices.size(), 0.0);
      for (size_t e = 0; e < mesh.size(); ++e) {
        const size_t b = block_of_[e];
        double mean = 0.0;
        for (int c = 0; c < C_; ++c) mean += B_[c][b];
        mean /= C_;
        for (uint32_t vtx : mesh.element_vertices(e)) {
          vertex_sum_[vtx] += mesh.area[e] * mean;
          vertex_weight_[vtx] += mesh.area[e];
        }
      }
      std::vector<size_t> offenders;
      for (size_t b = 0; b < blocks_.size(); ++b) {
        if (blocks_[b].fine.size() < 2) continue;
        double lo = 1e300, hi = -1e300;
        for (uint32_t e : blocks_[b].fine)
          for (uint32_t vtx : mesh.element_vertices(e)) {
            const double value = vertex_sum_[vtx] / vertex_weight_[vtx];
            lo = std::min(lo, value);
            hi = std::max(hi, value);
          }
        if (hi - lo > limit) offenders.push_back(b);
      }
      if (offenders.empty()) return;
      for (size_t b : offenders) split(b, &Ap);
    }
  }

  void refresh() const {
    if (!dirty_) return;
    const size_t n = block_of_.size();
    fine_B_ = Radiosity(C_, n);
    fine_dB_ = Radiosity(C_, n);
    for (int c = 0; c < C_; ++c)
      for (size_t e = 0; e < n; ++e) {
        fine_B_.at(c, e) = B_[c][block_of_[e]];
        fine_dB_.at(c, e) = dB_[c][block_of_[e]];
      }
    dirty_ = false;
  }

  AdaptiveOptions options_;
  const System* system_ = nullptr;
  int C_ = 1;
  std::vector<Block> blocks_;
  std::vector<uint32_t> block_of_;    // per fine element
  std::vector<double> B_[3], dB_[3];  // per block
  std::vector<double> delta_[3];      // per block: this step's delivery
  double shot_[3] = {0.0, 0.0, 0.0};  // this step's dB_p
  std::vector<double> row_;           // this step's patch row (fine elements)
  std::vector<double> vertex_sum_, vertex_weight_;
  std::vector<double> interreflection_;  // R_c (ambient)
  mutable Radiosity fine_B_, fine_dB_;
  mutable bool dirty_ = true;
};

}  // namespace

std::vector<uint32_t> adaptive_blocks(const Solver& solver) {
  const auto* adaptive = dynamic_cast<const AdaptiveShootingSolver*>(&solver);
  return adaptive ? adaptive->block_of() : std::vector<uint32_t>{};
}

SolverInfo adaptive_shooting_solver_info() {
  return {"adaptive-shooting",
          "sorted patch shooting to elements split where vertex radiosities jump; needs patches",
          "Cohen et al. 1988 §3.4, §4 (adaptive subdivision)",
          "one patch row (pair evaluations: one per current element)",
          {{"threshold", "", "split where vertex radiosities differ by more than this x mean B-E"},
           {"levels", "", "initial splits of every patch"},
           {"ambient", "", "add Cohen's display-only ambient term to display()"}},
          [](ParamBag& bag) -> std::unique_ptr<Solver> {
            return std::make_unique<AdaptiveShootingSolver>(AdaptiveOptions::from(bag));
          },
          SolverKind::kShooting};
}

}  // namespace radlab
