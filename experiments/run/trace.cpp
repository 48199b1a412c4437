#include "experiments/run/trace.h"

#include <cmath>
#include <cstdio>

#include "core/text.h"
#include "experiments/problem/problem.h"
#include "experiments/run/runner.h"

namespace radlab {
namespace {

using Row = TraceCheckpoint;
using Write = std::function<void(CsvWriter&, const Row&)>;

// An error metric: empty (NaN) without a reference to measure against.
Write measured(double (*value)(const Row&)) {
  return [value](CsvWriter& csv, const Row& r) { csv.add(r.measured ? value(r) : std::nan("")); };
}

ColumnTable<TraceCheckpoint> make_trace_table() {
  // clang-format off
  return {
    {"run_id", "`solver/scene:NAME[/subdiv:K\\|/element_size:S][/seed:S]/key:value...` (NAME: a builtin's spec or a scene file's stem), the same for `solve` and `run`; unique per run",
     [](CsvWriter& c, const Row& r) { c.add(r.labels.run_id); }},
    {"scene", "the scene spec", [](CsvWriter& c, const Row& r) { c.add(r.labels.scene); }},
    {"solver", "the solver's name", [](CsvWriter& c, const Row& r) { c.add(r.labels.solver); }},
    {"params", "the solver's parameters as given, `k=v,...`",
     [](CsvWriter& c, const Row& r) { c.add(r.labels.params); }},
    {"channel", "`mean` (mean of the colour channels) or `r`, `g`, `b`",
     [](CsvWriter& c, const Row& r) { c.add(r.channel); }},
    {"step", "solver steps taken (0 = the initial state)",
     [](CsvWriter& c, const Row& r) { c.add(r.step); }},
    {"ff_rows", "form-factor rows read so far (the x-axis of the papers' plots: one \"hemicube\")",
     [](CsvWriter& c, const Row& r) { c.add(r.ff_rows); }},
    {"seconds", "solver time so far; metric evaluation excluded",
     [](CsvWriter& c, const Row& r) { c.add(r.seconds); }, true},
    {"rms", "Cohen 1988 eq. 14, area-weighted", measured([](const Row& r) { return r.errors.rms; })},
    {"rms_rel", "`rms` divided by the reference's area-weighted RMS",
     measured([](const Row& r) { return r.errors.rms_rel; })},
    {"p_mean", "Wu & Wang p-error: area-weighted mean \\|p\\|",
     measured([](const Row& r) { return r.errors.p_mean; })},
    {"p_rms", "area-weighted RMS of p", measured([](const Row& r) { return r.errors.p_rms; })},
    {"p_max", "max \\|p\\|", measured([](const Row& r) { return r.errors.p_max; })},
    {"p_over", "area fraction with p > +1%", measured([](const Row& r) { return r.errors.p_over; })},
    {"p_under", "area fraction with p < −1%",
     measured([](const Row& r) { return r.errors.p_under; })},
    {"p_excluded", "elements left out of p-error: reference ≤ 1e-9 of its area-weighted mean, i.e. dark (until issue 35.4: of its max, which beside a 0.3 mm lamp left out the whole room); summary.csv's `p_excluded_area` gives their area fraction",
     [](CsvWriter& c, const Row& r) { c.add(static_cast<unsigned long long>(r.errors.p_excluded)); }},
    {"rms_display", "`rms` of `display()` (e.g. with Cohen's ambient term)",
     measured([](const Row& r) { return r.display.rms; })},
    {"rms_rel_display", "`rms_rel` of `display()`",
     measured([](const Row& r) { return r.display.rms_rel; })},
    {"p_mean_display", "`p_mean` of `display()`",
     measured([](const Row& r) { return r.display.p_mean; })},
    {"p_rms_display", "`p_rms` of `display()`",
     measured([](const Row& r) { return r.display.p_rms; })},
    {"p_max_display", "`p_max` of `display()`",
     measured([](const Row& r) { return r.display.p_max; })},
    {"residual_inf", "`‖E − (I − diag(ρ)F) B‖∞` (worst channel for `mean`), with its rounding bound",
     [](CsvWriter& c, const Row& r) { c.add(r.residual_inf); }},
    {"bound_inf", "certified `‖B − B*‖∞ ≤ residual_inf × ‖(I−J)⁻¹‖∞`",
     [](CsvWriter& c, const Row& r) { c.add(r.bound_inf); }},
    {"unshot_power", "`Σ A_i ΔB_i` for shooting solvers",
     [](CsvWriter& c, const Row& r) {
       c.add(r.unshot ? total_power(*r.unshot, r.problem.system->area(), r.field) : std::nan(""));
     }},
    {"total_power", "`Σ A_i B_i`",
     [](CsvWriter& c, const Row& r) { c.add(total_power(r.B, r.problem.system->area(), r.field)); }},
    {"rays", "visibility rays charged to the solver (on-the-fly rows, and rays a solver casts itself)",
     [](CsvWriter& c, const Row& r) { c.add(r.rays); }},
    {"pair_evals", "the work column common to every solver: element-pair form factors evaluated so far. A flat row counts n (it holds n pair form factors, cached or not); a hierarchical link, a refinement estimate or a patch-to-element entry counts 1; so does a Monte Carlo ray (stochastic-jacobi, random-walk: a cosine ray from element i samples the one pair i → j it lands on; an escaping ray counts too). Plots offer it as an x-axis beside `ff_rows` and `seconds`",
     [](CsvWriter& c, const Row& r) { c.add(r.pair_evals); }},
    {"rms_reflected", "Cohen's eq. 14 on the reflected part, `B − E` against `B* − E`: the emitters, right from step 0 for every solver, drop out (the plain `rms_rel` is already ≈ 0.1 at B = E on the Cornell box)",
     measured([](const Row& r) { return r.reflected.rms; })},
    {"rms_rel_reflected", "`rms_reflected` relative to the reference's; summary.csv's `*_to_rms_rel_reflected_*` columns use it",
     measured([](const Row& r) { return r.reflected.rms_rel; })},
    {"reference_kind", "what the errors are measured against: `certified` (the certified reference of the same system), the name of an uncertified stand-in (e.g. a much finer hierarchical run on scenes too large for the dense reference), or `none`",
     [](CsvWriter& c, const Row& r) {
       c.add(r.problem.reference ? r.problem.reference->kind : std::string("none"));
     }},
    {"solver_elements", "unknowns the solver itself holds (the mesh's n for flat solvers, leaves for hierarchical radiosity, current elements for adaptive subdivision): a change marks a change of the solver's mesh",
     [](CsvWriter& c, const Row& r) {
       const size_t own = r.solver.solver_elements();
       c.add(own > 0 ? own : r.problem.system->size());
     }},
    {"solver_statistics", "the solver's own counters so far (`Solver::statistics()`: hierarchical radiosity's nodes, links, rays, refinements ...) as `name=value;...`; empty for solvers without any. Those that measure the machine (time, peak RSS) are in run.json only",
     [](CsvWriter& c, const Row& r) { c.add(r.statistics); }},
    {"seconds_with_setup", "`seconds` plus the set-up the run has depended on so far: once it has read a row of the dense matrix (cached rows), that matrix's build time (the original build's, as the cache recorded it, when loaded from the cache); on two levels, the patch rows' build time. Nothing is added for rows on the fly (computed inside the steps), for hierarchical radiosity (its refinement is in its steps) or for the matrix-free Monte Carlo solvers (their rays are), nor for a matrix built only for the reference. The x-axis that compares a solver needing a matrix with one that does not",
     [](CsvWriter& c, const Row& r) { c.add(r.seconds_with_setup); }, true},
    {"cpu_seconds", "CPU time so far over the span `seconds` measures (the solver's init and steps, with the runner's budget checks between them; metric evaluation excluded), every thread of the process counted: beside the wall `seconds` it shows how many cores the solver kept busy, and it compares runs made at different loads, where wall time also measures the other work on the machine",
     [](CsvWriter& c, const Row& r) { c.add(r.cpu_seconds); }, true},
  };
  // clang-format on
}

}  // namespace

const ColumnTable<TraceCheckpoint>& trace_table() {
  static const ColumnTable<TraceCheckpoint> table = make_trace_table();
  return table;
}

std::vector<std::string> trace_columns() {
  return column_names(trace_table());
}

std::vector<std::string> trace_time_columns() {
  std::vector<std::string> names;
  for (const auto& column : trace_table())
    if (column.time) names.push_back(column.name);
  return names;
}

TraceWriter::TraceWriter(const std::string& path, const ColumnTable<TraceCheckpoint>& table)
    : table_(table), csv_(path, column_names(table)) {}

std::string statistics_field(const std::vector<std::pair<std::string, double>>& statistics) {
  std::string field;
  for (const auto& [name, value] : statistics) {
    // Measurements of the machine, not of the computation: time and the process's peak memory.
    if (name.find("seconds") != std::string::npos || name.find("rss") != std::string::npos)
      continue;
    char number[32];
    std::snprintf(number, sizeof number, "%.10g", value);
    field += (field.empty() ? "" : ";") + name + "=" + number;
  }
  return field;
}

}  // namespace radlab
