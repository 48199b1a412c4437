#include "formfactor/matrix/diagnostics.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <map>
#include <utility>

#include "core/param_bag.h"
#include "core/text.h"
#include "scene/overlap.h"

namespace radlab {

MatrixDiagnostics diagnose(const FormFactorMatrix& m, std::span<const double> area) {
  MatrixDiagnostics d;
  const size_t n = m.size();
  d.row_sum_min = n ? 1e300 : 0.0;
  d.row_sum_max = n ? -1e300 : 0.0;
  double largest = 0.0;
  for (size_t i = 0; i < n; ++i) {
    double sum = 0.0;
    m.visit_row(i, [&](const auto* row) {
      for (size_t j = 0; j < n; ++j) {
        const double f = double(row[j]);
        if (!std::isfinite(f)) {
          ++d.non_finite_entries;
          continue;
        }
        if (f < 0) ++d.negative_entries;
        if (f != 0) ++d.nonzero_entries;
        sum += f;
        largest = std::max(largest, area[i] * f);
      }
    });
    d.row_sum_min = std::min(d.row_sum_min, sum);
    d.row_sum_max = std::max(d.row_sum_max, sum);
  }
  // A pair where both entries are zero has no defect, so every pair with a non-zero entry is
  // visited from that entry's row (some twice: the maximum does not mind). With a sparse matrix
  // this reads O(non-zeros) entries of the other row instead of n^2.
  for (size_t i = 0; i < n; ++i)
    m.visit_row(i, [&](const auto* row) {
      for (size_t j = 0; j < n; ++j) {
        if (row[j] == 0 || j == i) continue;
        const double a = area[i] * double(row[j]), b = area[j] * m.at(j, i);
        if (!std::isfinite(a) || !std::isfinite(b)) continue;
        const double defect = std::abs(a - b);
        d.reciprocity_defect = std::max(d.reciprocity_defect, defect);
        const double scale = std::max(a, b);
        if (scale > 1e-12 * largest)
          d.reciprocity_defect_relative = std::max(d.reciprocity_defect_relative, defect / scale);
      }
    });
  return d;
}

std::string MatrixDiagnostics::summary() const {
  char buffer[400];
  std::snprintf(buffer, sizeof buffer,
                "row sums [%.9g, %.9g], reciprocity defect %.3g (relative %.3g), %zu non-zero, "
                "%zu negative, %zu non-finite entries",
                row_sum_min, row_sum_max, reciprocity_defect, reciprocity_defect_relative,
                nonzero_entries, negative_entries, non_finite_entries);
  return buffer;
}

double stated_row_sum_error(const FormFactorMethod& method, std::string* basis) {
  return method.stated_row_sum_error(basis);
}

namespace {

// Why entry (i, j) of a row that sums above 1 is as large as it is. Looks for another entry k of
// the same row whose element lies on (coplanar overlap) or just above/below j's (stacked): both
// then receive i's light where one surface hides the other. Otherwise, with F^u known, a partly
// occluded pair, and else a near or a plain unoccluded pair.
std::string classify(const FormFactorMatrix& m, const Mesh& mesh, double diagonal, size_t i,
                     size_t j, double f, double fu, std::string& kind) {
  const Vec3 nj = mesh.normal[j], cj = mesh.centroid[j];
  const double distance = glm::distance(mesh.centroid[i], cj);
  std::vector<Vec3> corners_j, corners_k;
  mesh.corners(j, corners_j);
  double best_gap = 1e300;
  size_t best = size_t(-1);
  double best_shared = 0.0;
  for (size_t k = 0; k < m.size(); ++k) {
    if (k == j || k == i || m.at(i, k) <= 0.0) continue;
    if (glm::dot(mesh.normal[k], nj) < 1.0 - 1e-6) continue;
    const double gap = std::abs(glm::dot(mesh.centroid[k] - cj, nj));
    if (gap > 0.01 * distance || gap >= best_gap) continue;
    mesh.corners(k, corners_k);
    const double shared = geometry::overlap_area(corners_j, corners_k);
    if (!(shared > 1e-3 * std::min(mesh.area[j], mesh.area[k]))) continue;
    best_gap = gap, best = k, best_shared = shared;
  }
  char buffer[300];
  if (best != size_t(-1)) {
    const double share = best_shared / mesh.area[j];
    // Closer than kCoincidentTolerance the loader merges the two (scene/overlap.h);
    // farther, the rays of the pair should see the stacked surface (visibility.cpp ends them within
    // a few float roundings of j), so a row still above 1 points at the estimate of V.
    if (best_gap <= kCoincidentTolerance * diagonal) {
      kind = "coplanar overlap";
      std::snprintf(buffer, sizeof buffer,
                    "coplanar overlap: %.0f%% of it coincides with element %zu (F %.4g), the same "
                    "surface twice",
                    100 * share, best, m.at(i, best));
    } else {
      kind = "stacked";
      std::snprintf(buffer, sizeof buffer,
                    "stacked: element %zu (F %.4g) lies %.3g m from it over %.0f%% of it, facing "
                    "the same way (%.3g of the pair's distance)",
                    best, m.at(i, best), best_gap, 100 * share, best_gap / distance);
    }
    return buffer;
  }
  if (fu >= 0 && f < fu * (1 - 1e-6)) {
    kind = "partly occluded";
    std::snprintf(buffer, sizeof buffer,
                  "partly occluded: F^u %.4g, visible fraction %.3f (equal-weight rays)", fu,
                  f / fu);
    return buffer;
  }
  double ri = 0, rj = 0;
  for (uint32_t v : mesh.element_vertices(i))
    ri = std::max(ri, glm::distance(mesh.vertices[v], mesh.centroid[i]));
  for (uint32_t v : mesh.element_vertices(j))
    rj = std::max(rj, glm::distance(mesh.vertices[v], cj));
  if (distance < ri + rj) {
    kind = "near pair";
    std::snprintf(buffer, sizeof buffer,
                  "near or touching pair (centroids %.3g m apart, radii %.3g + %.3g)%s", distance,
                  ri, rj, fu >= 0 ? ", unoccluded" : "");
    return buffer;
  }
  kind = fu >= 0 ? "unoccluded" : "unclassified";
  return fu >= 0 ? "unoccluded, nothing stacked on it"
                 : "no stacked or coplanar partner in the row";
}

// The verdict on row sums: range, and the rows above 1 + stated_error + (the row's allowance,
// asked only of rows above the common limit: it may cost a row), into `above` (and `allowance`,
// sized n when row_allowance is given).
RowSumCheck row_sum_verdict(std::span<const double> sums, double stated_error,
                            const std::function<double(size_t)>& row_allowance,
                            std::vector<size_t>& above, std::vector<double>& allowance) {
  RowSumCheck check;
  check.stated_error = stated_error;
  check.per_row = bool(row_allowance);
  const size_t n = sums.size();
  check.row_sum_min = n ? *std::min_element(sums.begin(), sums.end()) : 0.0;
  check.row_sum_max = n ? *std::max_element(sums.begin(), sums.end()) : 0.0;
  for (size_t i = 0; i < n; ++i)
    if (sums[i] > 1.0 + stated_error) {
      if (row_allowance) allowance[i] = row_allowance(i);
      if (sums[i] > 1.0 + stated_error + (row_allowance ? allowance[i] : 0.0)) above.push_back(i);
    }
  check.rows_above = above.size();
  return check;
}

// A method's row-sum limits: its common stated error and, where it states them, each row's own
// allowance (empty function otherwise).
std::pair<double, std::function<double(size_t)>> row_sum_limits(const FormFactorMethod& method) {
  if (!method.states_row_allowances()) return {method.stated_row_sum_error(), {}};
  return {method.row_sum_error_common(),
          [&method](size_t i) { return method.row_sum_allowance(i); }};
}

}  // namespace

RowSumCheck check_row_sums(std::span<const double> sums, const FormFactorMethod& method) {
  const auto [stated_error, row_allowance] = row_sum_limits(method);
  std::vector<size_t> above;
  std::vector<double> allowance(row_allowance ? sums.size() : 0, 0.0);
  return row_sum_verdict(sums, stated_error, row_allowance, above, allowance);
}

RowSumCheck check_row_sums(const FormFactorMatrix& m, const Scene& scene, const Mesh& mesh,
                           double stated_error,
                           const std::function<double(size_t, size_t)>& unoccluded,
                           size_t worst_rows, size_t entries_per_row,
                           const std::function<double(size_t)>& row_allowance) {
  (void)scene;
  const size_t n = m.size();
  std::vector<double> sums(n, 0.0);
  for (size_t i = 0; i < n; ++i)
    sums[i] = m.visit_row(i, [&](const auto* row) {
      double s = 0.0;
      for (size_t j = 0; j < n; ++j) s += double(row[j]);
      return s;
    });
  std::vector<size_t> above;
  std::vector<double> allowance(row_allowance ? n : 0, 0.0);
  RowSumCheck check = row_sum_verdict(sums, stated_error, row_allowance, above, allowance);
  if (above.empty()) return check;
  std::sort(above.begin(), above.end(), [&](size_t a, size_t b) { return sums[a] > sums[b]; });
  Vec3 lo(1e300), hi(-1e300);
  for (const Vec3& v : mesh.vertices) lo = glm::min(lo, v), hi = glm::max(hi, v);
  const double diagonal = glm::length(hi - lo);
  // Every row above is classified by its largest entries (for the tally); the worst are kept in
  // full. Capped at 2,000 rows so that a badly broken large scene still answers in seconds.
  std::map<std::string, size_t> tally;
  const size_t classified = std::min<size_t>(above.size(), 2000);
  for (size_t r = 0; r < classified; ++r) {
    const size_t i = above[r];
    std::vector<std::pair<double, size_t>> largest;
    for (size_t j = 0; j < n; ++j)
      if (double f = m.at(i, j); f > 0) largest.emplace_back(f, j);
    const size_t keep = std::min(entries_per_row, largest.size());
    std::partial_sort(largest.begin(), largest.begin() + long(keep), largest.end(),
                      [](const auto& a, const auto& b) { return a.first > b.first; });
    RowSumCheck::Row row{i, sums[i], row_allowance ? allowance[i] : 0.0, {}};
    for (size_t e = 0; e < keep; ++e) {
      const auto [f, j] = largest[e];
      const double fu = unoccluded ? unoccluded(i, j) : -1.0;
      std::string kind;
      std::string cause = classify(m, mesh, diagonal, i, j, f, fu, kind);
      ++tally[kind];
      row.entries.push_back({j, f, fu, std::move(cause)});
    }
    if (check.worst.size() < worst_rows) check.worst.push_back(std::move(row));
  }
  for (auto& [kind, count] : tally) check.tally.emplace_back(kind, count);
  std::sort(check.tally.begin(), check.tally.end(),
            [](const auto& a, const auto& b) { return a.second > b.second; });
  return check;
}

RowSumCheck check_row_sums(const FormFactorMatrix& matrix, const Scene& scene, const Mesh& mesh,
                           const FormFactorMethod& method) {
  const auto unoccluded = [&method](size_t i, size_t j) { return method.unoccluded_pair(i, j); };
  const auto [stated_error, row_allowance] = row_sum_limits(method);
  return check_row_sums(matrix, scene, mesh, stated_error, unoccluded, 5, 4, row_allowance);
}

std::string RowSumCheck::headline() const {
  char buffer[300];
  std::snprintf(
      buffer, sizeof buffer,
      "row sums of F [%.6g, %.6g]; %zu row%s above 1 + %.3g%s (the method's stated error)",
      row_sum_min, row_sum_max, rows_above, rows_above == 1 ? "" : "s", stated_error,
      per_row ? " + the row's visibility and quadrature allowance" : "");
  std::string out = buffer;
  if (!tally.empty()) {
    out += "; largest entries of those rows:";
    for (size_t k = 0; k < tally.size(); ++k)
      out += (k ? ", " : " ") + std::to_string(tally[k].second) + " " + tally[k].first;
  }
  return out;
}

std::string RowSumCheck::report(const Scene& scene, const Mesh& mesh) const {
  std::string out = headline();
  auto polygon = [&](size_t e) {
    const Polygon& p = scene.polygons[mesh.polygon[e]];
    return "element " + std::to_string(e) + " of " + p.origin + " ('" +
           scene.materials[size_t(p.material)].name + "')";
  };
  char buffer[160];
  for (const Row& row : worst) {
    if (per_row)
      std::snprintf(buffer, sizeof buffer, "\n  row sum %.6g (limit 1 + %.3g + %.3g): ", row.sum,
                    stated_error, row.allowance);
    else
      std::snprintf(buffer, sizeof buffer, "\n  row sum %.6g: ", row.sum);
    out += buffer + polygon(row.i);
    for (const Entry& e : row.entries) {
      std::snprintf(buffer, sizeof buffer, "\n    F %.4g to ", e.f);
      out += buffer + polygon(e.j) + ": " + e.cause;
    }
  }
  return out;
}

double emitted_power_ratio(const FormFactorMatrix& m, const Scene& scene, const Mesh& mesh) {
  const size_t n = m.size();
  std::vector<std::pair<size_t, double>> emitters;  // element, E summed over channels
  for (size_t e = 0; e < n; ++e) {
    const Rgb& E = scene.materials[size_t(scene.polygons[mesh.polygon[e]].material)].emission;
    if (E.x + E.y + E.z > 0) emitters.emplace_back(e, E.x + E.y + E.z);
  }
  if (emitters.empty()) return 1.0;
  double sent = 0.0, gathered = 0.0;
  for (const auto& [j, E] : emitters) {
    double row = 0.0;
    for (size_t i = 0; i < n; ++i) row += m.at(j, i);
    sent += E * mesh.area[j] * row;
  }
  for (size_t i = 0; i < n; ++i)
    for (const auto& [j, E] : emitters) gathered += E * mesh.area[i] * m.at(i, j);
  return sent > 0 ? gathered / sent : (gathered > 0 ? 1e300 : 1.0);
}

EmitterSamplingReport emitter_sampling_report(const FormFactorMethod& method, const Mesh& mesh) {
  EmitterSamplingReport report;
  const size_t n = mesh.size();
  std::vector<FormFactorMethod::EmitterSampling> rows(n);
  double largest = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const auto row = method.row_emitter_sampling(i);
    if (!row || std::isnan(row->error) || std::isnan(row->exact)) return report;  // not stated
    rows[i] = *row;
    largest = std::max(largest, row->exact);
  }
  report.stated = true;
  double error = 0.0, exact = 0.0;
  for (size_t i = 0; i < n; ++i) {
    error += mesh.area[i] * rows[i].error;
    exact += mesh.area[i] * rows[i].exact;
    if (rows[i].exact >= 1e-3 * largest && rows[i].exact > 0) {
      const double relative = rows[i].error / rows[i].exact;
      if (relative > report.worst_relative) {
        report.worst_relative = relative;
        report.worst_element = i;
      }
    }
  }
  report.relative = exact > 0 ? error / exact : 0.0;
  return report;
}

std::string EmitterSamplingReport::text() const {
  char buffer[200];
  std::snprintf(buffer, sizeof buffer,
                "the rows sample the emitters to within %.3g%% of the direct power the elements "
                "gather (worst: element %zu, %.3g%% of its direct light)",
                100.0 * relative, worst_element, 100.0 * worst_relative);
  return buffer;
}

}  // namespace radlab
