// aggregate.csv: one row per configuration that a sweep ran over several solver seeds (the
// experiment's `solver_seeds` or `repeats`): the mean of each final error over the seeds, its
// sample standard deviation, and a 90% band, the Student-t confidence interval of the mean,
// mean ± t(0.95, K−1) s/√K. Computed from summary.csv's rows (the `configuration` and
// `solver_seed` columns), so a sweep and a merge of its shards write the same file.
//
// Why the t interval and not the empirical 5%/95% quantiles of the K runs: the band is there to
// compare configurations (is one's expected error below another's?), which is a statement about
// the mean; and at the K of a sweep (4 to 64) empirical 5%/95% quantiles are the extreme runs
// (K = 4: the band would be min..max, with no stated level). A final error over seeds is a mean
// over many elements' errors, close to normal, which is what the t interval assumes; `_sd` gives
// the spread of a single run beside it.
#pragma once

#include <string>
#include <vector>

#include "core/csv_reader.h"
#include "experiments/run/columns.h"

namespace radlab {

// The runs of one configuration over its seeds.
struct SeedGroup {
  std::string configuration, scene, solver;
  std::string params;              // the solver's parameters without `seed`
  std::vector<std::string> seeds;  // of the runs that finished, in run order
  size_t failed = 0;               // runs of it that failed (left out of the statistics)
  // One vector per aggregated metric (aggregated_metrics() order), one value per finished seed.
  std::vector<std::vector<double>> values;
};

// The summary columns aggregated: rms_rel, rms_rel_reflected, p_mean, p_max.
const std::vector<std::string>& aggregated_metrics();

// The two-sided 90% Student-t factor t(0.95, samples − 1) (Boost.Math); NaN below 2 samples.
double student_t_90(size_t samples);

// Groups the summary's rows that have a solver seed by configuration, in run order.
std::vector<SeedGroup> seed_groups(const CsvTable& summary);

// aggregate.csv's columns (columns.h): header, rows and docs/outputs.md's table come from it.
const ColumnTable<SeedGroup>& aggregate_table();

// Writes `path` from the summary when any run has a solver seed; returns whether it did.
bool write_seed_aggregate(const CsvTable& summary, const std::string& path);

}  // namespace radlab
