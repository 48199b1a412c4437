// Patch rows from the form-factor method and K's rows from them (see patch_rows.h).
#include "solvers/two_level/patch_rows.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <stdexcept>
#include <vector>

#include "core/error.h"
#include "core/text.h"
#include "formfactor/registry.h"

namespace radlab {

PatchRowRule patch_row_rule(const std::string& name) {
  if (name == "centre") return PatchRowRule::kCentre;
  if (name == "mean") return PatchRowRule::kMean;
  throw UsageError("patches: rows must be centre or mean, got '" + name + "'");
}

std::string patch_row_rule_name(PatchRowRule rule) {
  return rule == PatchRowRule::kCentre ? "centre" : "mean";
}

std::string PatchRowReport::summary() const {
  char buffer[300];
  std::snprintf(buffer, sizeof buffer,
                "%zu method rows in %.2f s; max patch row sum %.6g, max element-to-patch sum "
                "%.6g",
                method_rows, seconds, max_row_sum, max_gather_sum);
  return buffer;
}

namespace {

// The method's row at patch p's centre into row (double), in the plane and frame of its first
// element; false when the method takes no rows at a point.
bool centre_row(const FormFactorMethod& method, const Mesh& mesh, const Patches& patches, size_t p,
                std::vector<double>& row, RowCost& cost) {
  const auto members = patches.members(p);
  const uint32_t first = members[0];
  // One element: its own eye and frame, so the row is its element row bit for bit.
  Vec3 eye = mesh.centroid[first];
  if (members.size() > 1) {
    eye = Vec3(0.0);
    for (uint32_t e : members) eye += mesh.area[e] * mesh.centroid[e];
    eye /= patches.area(p);
  }
  return method.row_at_point(eye, first, row, cost);
}

}  // namespace

RowMatrix compute_patch_rows(const FormFactorMethod& method, const Mesh& mesh,
                             const Patches& patches, PatchRowRule rule, Precision precision,
                             PatchRowReport& report,
                             const std::function<void(size_t done, size_t total)>& progress) {
  const auto start = std::chrono::steady_clock::now();
  const size_t n = mesh.size(), P = patches.size();
  // The method's registry entry says whether its rows are taken at a point (the method
  // conformance tests hold row_at_point() to it).
  if (rule == PatchRowRule::kCentre && !form_factor_method_info(method.name()).rows_at_points) {
    std::vector<std::string> at_points;
    for (const FormFactorMethodInfo& info : form_factor_methods())
      if (info.rows_at_points) at_points.push_back(info.name);
    throw UsageError("patches: rows = \"centre\" (one row at each patch's centre) needs --ff " +
                     text::join(at_points, " or ") + " (rows taken at a point); form factors '" +
                     method.name() + "' integrate over the source: use rows = \"mean\"");
  }
  RowMatrix rows(P, n, precision);
  std::mutex merge;
  std::atomic<size_t> done{0};
  report = PatchRowReport{};
  // Chunks of patches in parallel, progress between them (from this thread only).
  const size_t chunk = std::max<size_t>(1, P / 50);
  for (size_t begin = 0; begin < P; begin += chunk) {
    const size_t end = std::min(P, begin + chunk);
    tbb::parallel_for(
        tbb::blocked_range<size_t>(begin, end), [&](const tbb::blocked_range<size_t>& range) {
          RowCost cost;
          size_t computed = 0;
          std::vector<double> row(n), element(n);
          for (size_t p = range.begin(); p != range.end(); ++p) {
            if (rule == PatchRowRule::kCentre) {
              if (!centre_row(method, mesh, patches, p, row, cost))
                throw std::logic_error(method.name() + ": rows_at_points but no row_at_point()");
              ++computed;
            } else {
              std::fill(row.begin(), row.end(), 0.0);
              const auto members = patches.members(p);
              const auto weights = patches.weights(p);
              for (size_t k = 0; k < members.size(); ++k) {
                method.row(members[k], element, cost);
                for (size_t e = 0; e < n; ++e) row[e] += weights[k] * element[e];
                ++computed;
              }
            }
            for (size_t e = 0; e < n; ++e) rows.set(p, e, row[e]);
          }
          std::lock_guard<std::mutex> lock(merge);
          report.cost += cost;
          report.method_rows += computed;
        });
    done = end;
    if (progress) progress(done, P);
  }
  // Row sums of what is stored, and the element-to-patch sums reciprocity gives (docs).
  std::vector<double> gather(n, 0.0);
  for (size_t p = 0; p < P; ++p) {
    double sum = 0.0;
    rows.visit_row(p, [&](const auto* r) {
      for (size_t e = 0; e < n; ++e) {
        sum += double(r[e]);
        gather[e] += double(r[e]) * patches.area(p) / mesh.area[e];
      }
    });
    report.max_row_sum = std::max(report.max_row_sum, sum);
  }
  for (double g : gather) report.max_gather_sum = std::max(report.max_gather_sum, g);
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return rows;
}

TwoLevelRows::TwoLevelRows(const Mesh& mesh, const Patches& patches, const RowMatrix& rows)
    : mesh_(mesh), patches_(patches), rows_(rows) {
  if (patches.elements() != mesh.size() || rows.rows() != patches.size() ||
      rows.columns() != mesh.size())
    throw std::invalid_argument("TwoLevelRows: parts of different sizes");
}

void TwoLevelRows::row(size_t e, std::span<double> out, RowCost& cost) const {
  const double inverse_area = 1.0 / mesh_.area[e];
  for (size_t p = 0; p < patches_.size(); ++p) {
    // F_{e,p} by reciprocity, then spread over p's elements by area (weights exactly 1 for a
    // one-element patch).
    const double to_patch = rows_.at(p, e) * (patches_.area(p) * inverse_area);
    const auto members = patches_.members(p);
    const auto weights = patches_.weights(p);
    for (size_t k = 0; k < members.size(); ++k) out[members[k]] = to_patch * weights[k];
  }
  cost.kernel_evaluations += patches_.size();
}

double TwoLevelRows::stated_row_sum_error(std::string* basis) const {
  std::vector<double> gather(mesh_.size(), 0.0);
  for (size_t p = 0; p < patches_.size(); ++p)
    for (size_t e = 0; e < mesh_.size(); ++e)
      gather[e] += rows_.at(p, e) * (patches_.area(p) / mesh_.area[e]);
  double largest = 0.0;
  for (double g : gather) largest = std::max(largest, g);
  const double excess = std::max(0.0, largest - 1.0) + kFloatStorageRowError;
  if (basis)
    *basis =
        "two levels: K's rows sum to the element-to-patch factors reciprocity gives; their "
        "largest excess over 1, measured, + float storage 1e-7";
  return excess;
}

RowMatrix block_rows(const RowMatrix& rows, std::span<const double> area,
                     std::span<const uint32_t> block_of) {
  const size_t n = rows.columns();
  if (area.size() != n || block_of.size() != n)
    throw std::invalid_argument("block_rows: parts of different sizes");
  size_t blocks = 0;
  for (uint32_t b : block_of) blocks = std::max<size_t>(blocks, size_t(b) + 1);
  std::vector<double> block_area(blocks, 0.0);
  for (size_t e = 0; e < n; ++e) block_area[block_of[e]] += area[e];
  RowMatrix out(rows.rows(), n, rows.precision());
  std::vector<double> sum(blocks);
  for (size_t p = 0; p < rows.rows(); ++p) {
    std::fill(sum.begin(), sum.end(), 0.0);
    for (size_t e = 0; e < n; ++e) sum[block_of[e]] += rows.at(p, e);
    for (size_t e = 0; e < n; ++e)
      out.set(p, e, sum[block_of[e]] * (area[e] / block_area[block_of[e]]));
  }
  return out;
}

FormFactorMatrix dense_two_level_matrix(const Mesh& mesh, const Patches& patches,
                                        const RowMatrix& rows, Precision precision) {
  const size_t n = mesh.size();
  FormFactorMatrix K(n, precision);
  TwoLevelRows gather(mesh, patches, rows);
  std::vector<double> row(n);
  RowCost cost;
  for (size_t e = 0; e < n; ++e) {
    gather.row(e, row, cost);
    for (size_t j = 0; j < n; ++j) K.set(e, j, row[j]);
  }
  return K;
}

}  // namespace radlab
