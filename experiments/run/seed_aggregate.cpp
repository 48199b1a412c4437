#include "experiments/run/seed_aggregate.h"

#include <algorithm>
#include <boost/math/distributions/students_t.hpp>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>

#include "core/csv.h"
#include "core/text.h"

namespace radlab {
namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

// A summary field as a number: empty (not applicable) or unreadable is NaN.
double number_of(const std::string& field) {
  if (field.empty()) return kNan;
  char* end = nullptr;
  const double value = std::strtod(field.c_str(), &end);
  return end == field.c_str() + field.size() ? value : kNan;
}

// The canonical `k=v,...` without the seed entry.
std::string without_seed(const std::string& params) {
  std::vector<std::string> kept;
  for (const std::string& entry : text::split(params, ','))
    if (!entry.empty() && !text::starts_with(entry, "seed=")) kept.push_back(entry);
  return text::join(kept, ",");
}

// Mean and sample standard deviation; NaN when a value is missing (a metric without a
// reference), and the deviation NaN below two values.
struct Moments {
  double mean = kNan, sd = kNan;
};
Moments moments(const std::vector<double>& v) {
  Moments m;
  if (v.empty()) return m;
  double sum = 0.0;
  for (double x : v) sum += x;  // a NaN anywhere makes the mean NaN, as it should
  m.mean = sum / double(v.size());
  if (v.size() < 2) return m;
  double squares = 0.0;
  for (double x : v) squares += (x - m.mean) * (x - m.mean);
  m.sd = std::sqrt(squares / double(v.size() - 1));
  return m;
}

double band(const std::vector<double>& v, int side) {
  const Moments m = moments(v);
  return m.mean + side * student_t_90(v.size()) * m.sd / std::sqrt(double(v.size()));
}

ColumnTable<SeedGroup> make_aggregate_table() {
  using Write = std::function<void(CsvWriter&, const SeedGroup&)>;
  ColumnTable<SeedGroup> t;
  auto add = [&t](std::string name, std::string meaning, Write write, bool time = false) {
    t.push_back({std::move(name), std::move(meaning), std::move(write), time});
  };
  // clang-format off
  add("configuration", "summary.csv's `configuration`: the run id without the solver's seed", [](CsvWriter& c, const SeedGroup& g) { c.add(g.configuration); });
  add("scene", "the scene spec", [](CsvWriter& c, const SeedGroup& g) { c.add(g.scene); });
  add("solver", "the solver's name", [](CsvWriter& c, const SeedGroup& g) { c.add(g.solver); });
  add("params", "the solver's parameters without `seed`, canonical `k=v,...`", [](CsvWriter& c, const SeedGroup& g) { c.add(g.params); });
  add("seeds", "K: the runs of the configuration that finished (the statistics' sample size)", [](CsvWriter& c, const SeedGroup& g) { c.add(g.seeds.size()); });
  add("seed_list", "their seeds, `;`-separated in run order", [](CsvWriter& c, const SeedGroup& g) { c.add(text::join(g.seeds, ";")); });
  add("failed", "runs of the configuration that failed (left out of the statistics; summary.csv says why)", [](CsvWriter& c, const SeedGroup& g) { c.add(g.failed); });
  add("t90", "the Student-t factor t(0.95, K−1) of the bands (empty below K = 2); the plots widen the trace's per-checkpoint bands with it", [](CsvWriter& c, const SeedGroup& g) { c.add(student_t_90(g.seeds.size())); });
  // clang-format on
  const std::vector<std::string>& metrics = aggregated_metrics();
  for (size_t m = 0; m < metrics.size(); ++m) {
    const std::string& name = metrics[m];
    add(name + "_mean", "mean over the seeds of the final `" + name + "`",
        [m](CsvWriter& c, const SeedGroup& g) { c.add(moments(g.values[m]).mean); });
    add(name + "_sd", "its sample standard deviation over the seeds (the spread of one run)",
        [m](CsvWriter& c, const SeedGroup& g) { c.add(moments(g.values[m]).sd); });
    add(name + "_band_low",
        "the 90% band's lower end: mean − t90 sd/√K, the Student-t confidence interval of the "
        "mean (experiments/run/seed_aggregate.h says why this estimator)",
        [m](CsvWriter& c, const SeedGroup& g) { c.add(band(g.values[m], -1)); });
    add(name + "_band_high", "its upper end, mean + t90 sd/√K",
        [m](CsvWriter& c, const SeedGroup& g) { c.add(band(g.values[m], +1)); });
  }
  return t;
}

}  // namespace

const std::vector<std::string>& aggregated_metrics() {
  static const std::vector<std::string> metrics = {"rms_rel", "rms_rel_reflected", "p_mean",
                                                   "p_max"};
  return metrics;
}

double student_t_90(size_t samples) {
  if (samples < 2) return kNan;
  const boost::math::students_t distribution(double(samples - 1));
  return boost::math::quantile(distribution, 0.95);
}

std::vector<SeedGroup> seed_groups(const CsvTable& summary) {
  // A summary from before the two columns (an older sweep being merged) has no seeds to group.
  for (const char* name : {"configuration", "solver_seed"})
    if (std::find(summary.header.begin(), summary.header.end(), name) == summary.header.end())
      return {};
  const size_t configuration = summary.column("configuration");
  const size_t seed = summary.column("solver_seed");
  const size_t scene = summary.column("scene"), solver = summary.column("solver");
  const size_t params = summary.column("params"), error = summary.column("error");
  std::vector<size_t> metric_columns;
  for (const std::string& name : aggregated_metrics())
    metric_columns.push_back(summary.column(name));
  std::vector<SeedGroup> groups;
  std::map<std::string, size_t> index;  // configuration -> position in groups
  for (const std::vector<std::string>& row : summary.rows) {
    if (row[seed].empty()) continue;
    auto [it, added] = index.emplace(row[configuration], groups.size());
    if (added) {
      SeedGroup g;
      g.configuration = row[configuration];
      g.scene = row[scene];
      g.solver = row[solver];
      g.params = without_seed(row[params]);
      g.values.resize(metric_columns.size());
      groups.push_back(std::move(g));
    }
    SeedGroup& g = groups[it->second];
    if (!row[error].empty()) {
      ++g.failed;
      continue;
    }
    g.seeds.push_back(row[seed]);
    for (size_t m = 0; m < metric_columns.size(); ++m)
      g.values[m].push_back(number_of(row[metric_columns[m]]));
  }
  return groups;
}

const ColumnTable<SeedGroup>& aggregate_table() {
  static const ColumnTable<SeedGroup> table = make_aggregate_table();
  return table;
}

bool write_seed_aggregate(const CsvTable& summary, const std::string& path) {
  const std::vector<SeedGroup> groups = seed_groups(summary);
  if (groups.empty()) return false;
  CsvWriter csv(path, column_names(aggregate_table()));
  for (const SeedGroup& g : groups) write_columns(csv, aggregate_table(), g);
  csv.close();
  return true;
}

}  // namespace radlab
