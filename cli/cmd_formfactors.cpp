// `radlab formfactors SCENE --out F.csv`: computes the form-factor matrix, prints its diagnostics
// and writes the non-zero entries as CSV `i,j,F` (element ids in input order).
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <numeric>
#include <optional>

#include "cli/cli_common.h"
#include "core/csv.h"
#include "core/error.h"
#include "core/log.h"
#include "core/output_file.h"
#include "core/progress.h"
#include "core/random.h"
#include "formfactor/matrix/matrix_cache.h"

namespace radlab::cli {
namespace {

struct SampleOptions {
  size_t rows = 0;
  bool verify_cache = false;
  uint64_t seed = 0;
};

// A double in as many digits as tell it from its neighbours.
std::string exact(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", value);
  return text;
}

// `--sample-rows N`: N distinct rows drawn at random (a seeded partial shuffle), computed on the
// fly in parallel and checked as a build checks every row (diagnostics.h), with the worst rows'
// entries and polygons. The rest of the matrix is neither computed nor stored: a scene whose
// whole matrix is out of reach (soda.mgf, 53,207 elements) can still be checked for light made.
void check_sampled_rows(const SceneOptions& scene, const FormFactorOptions& ff,
                        const SampleOptions& sample) {
  ProblemSpec spec = make_problem_spec(scene, ff);
  spec.need_reference = false;
  spec.require_emitter = false;
  spec.row_mode = RowMode::kOnTheFly;  // no matrix is built
  auto problem = prepare_problem(spec);
  const size_t n = problem->mesh.size();
  const size_t count = std::min(sample.rows, n);
  std::vector<uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  Pcg32 rng(sample.seed);
  for (size_t k = 0; k < count; ++k)
    std::swap(order[k], order[k + rng.next_below(uint32_t(n - k))]);
  std::vector<uint32_t> rows(order.begin(), order.begin() + std::ptrdiff_t(count));
  std::sort(rows.begin(), rows.end());
  std::printf("method       %s (%s)\n", spec.ff_method.c_str(), problem->ff_parameters.c_str());
  std::printf("elements     %zu\n", n);
  // --verify-cache: the cached matrix of this scene, mesh and method (the cache holds it in
  // double, as computed), whose sampled rows must be the bits computed here. A matrix merged from
  // blocks, or built by another process, is checked against this process's own rows.
  std::optional<FormFactorMatrix> cached;
  std::string cached_file;
  if (sample.verify_cache) {
    const MatrixCache cache(spec.cache_dir.empty() ? default_cache_dir()
                                                   : std::filesystem::path(spec.cache_dir));
    const MatrixCacheKey key = matrix_cache_key(problem->mesh, problem->method->name(),
                                                problem->method->parameters(), Precision::kDouble);
    cached_file = cache.path(key).string();
    BuildReport report;
    cached = cache.load(key, &report);
    if (!cached)
      throw InputError(cached_file + ": --verify-cache found no cached matrix of this scene, " +
                       "mesh and method (missing, or refused as damaged or of another key); " +
                       "build it first (radlab formfactors, or radlab prepare)");
  }
  std::atomic<size_t> differing{0};
  std::mutex first_mismatch;
  std::string mismatch;  // the first differing entry in row order
  uint64_t mismatch_at = ~uint64_t(0);
  FormFactorMatrix sampled(n, Precision::kDouble, Layout::kSparse);
  std::vector<double> sums(count, 0.0);
  std::mutex store;
  Progress progress("form factors (" + spec.ff_method + ", " + std::to_string(count) + " of " +
                        std::to_string(n) + " rows)",
                    "rows", double(count));
  std::atomic<size_t> done{0};
  const auto start = std::chrono::steady_clock::now();
  tbb::parallel_for(size_t(0), count, [&](size_t k) {
    thread_local std::vector<double> row;
    row.assign(n, 0.0);
    RowCost cost;
    problem->method->row(rows[k], row, cost);
    for (double f : row) sums[k] += f;
    if (cached) {
      for (size_t j = 0; j < n; ++j) {
        const double held = cached->at(rows[k], j);
        if (std::memcmp(&held, &row[j], sizeof(double)) == 0) continue;
        ++differing;
        const uint64_t at = uint64_t(rows[k]) * n + j;
        const std::lock_guard<std::mutex> lock(first_mismatch);
        if (at < mismatch_at) {
          mismatch_at = at;
          mismatch = "row " + std::to_string(rows[k]) + ", column " + std::to_string(j) +
                     ": cached " + exact(held) + ", computed " + exact(row[j]);
        }
      }
    }
    {
      const std::lock_guard<std::mutex> lock(store);
      sampled.set_row(rows[k], row);
    }
    progress.update(double(++done));
  });
  progress.finish();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  RowSumCheck check = check_row_sums(sampled, problem->scene(), problem->mesh, *problem->method);
  // Over the sampled rows only (the others are zero here, not computed).
  check.row_sum_min = count ? *std::min_element(sums.begin(), sums.end()) : 0.0;
  check.row_sum_max = count ? *std::max_element(sums.begin(), sums.end()) : 0.0;
  std::printf("sampled      %zu of %zu rows (seed %llu), computed in %.3f s\n", count, n,
              static_cast<unsigned long long>(sample.seed), seconds);
  if (cached && differing > 0)
    throw InputError(cached_file + ": " + std::to_string(differing.load()) + " of the " +
                     std::to_string(count * n) + " entries of the sampled rows differ from " +
                     "the rows computed now, first " + mismatch +
                     "; the cache holds another matrix than this radlab computes (delete the " +
                     "file to rebuild it)");
  if (cached)
    std::printf("verified     %s: all %zu entries of the sampled rows the same bits\n",
                cached_file.c_str(), count * n);
  std::string basis;
  stated_row_sum_error(*problem->method, &basis);
  std::printf("stated error %s\n", basis.c_str());
  std::printf("row sums     %s (the sampled rows)\n",
              check.report(problem->scene(), problem->mesh).c_str());
  for (const std::string& note : problem->method->left_out())
    std::printf("left out     %s\n", note.c_str());
}

// What was built: method, mesh, repairs, cost, diagnostics and the row-sum check.
void print_build(const Problem& problem) {
  std::printf("method       %s (%s)\n", problem.spec.ff_method.c_str(),
              problem.ff_parameters.c_str());
  std::printf("elements     %zu\n", problem.mesh.size());
  const ValidationReport& report = problem.loaded.report;
  std::printf(
      "repairs      %d degenerate polygons dropped, %d split into triangles, %d coincident "
      "same-facing overlaps removed (%d polygons dropped, %d cut), %d back-to-back kept, %d "
      "face-to-face contacts %s (%.4g m^2)\n",
      report.dropped, report.triangulated, report.overlaps.same_facing, report.overlaps.dropped,
      report.overlaps.clipped, report.overlaps.back_to_back, report.overlaps.contacts,
      problem.spec.keep_overlaps ? "kept (--keep-overlaps)" : "removed from both",
      report.overlaps.contact_area);
  std::printf(
      "time         %.3f s on %d threads%s\n", problem.build.seconds, problem.build.threads,
      problem.build.cached
          ? (" (when built; loaded now from the cache " + problem.build.cache_file + ")").c_str()
          : "");
  std::printf("rays         %llu\n", static_cast<unsigned long long>(problem.build.cost.rays));
  std::printf("pairs        %llu culled (facing away / coplanar), %llu unoccluded, %llu traced\n",
              static_cast<unsigned long long>(problem.build.cost.pairs_culled),
              static_cast<unsigned long long>(problem.build.cost.pairs_unoccluded),
              static_cast<unsigned long long>(problem.build.cost.pairs_traced));
  if (problem.ff_parameters.find("symmetrise=true") != std::string::npos) {
    std::printf("computed     %s\n", problem.raw_diagnostics.summary().c_str());
    std::printf("symmetrised  %s\n", problem.diagnostics.summary().c_str());
  } else {
    std::printf("diagnostics  %s\n", problem.diagnostics.summary().c_str());
  }
  // The row-sum check (formfactor/matrix/diagnostics.h): rows above 1 + the method's stated
  // error, with the worst rows' largest entries, their polygons and what makes each too large.
  std::string basis;
  stated_row_sum_error(*problem.method, &basis);
  std::printf("stated error %s\n", basis.c_str());
  std::printf("row sums     %s\n", problem.row_sums.report(problem.scene(), problem.mesh).c_str());
  if (problem.ff_parameters.find("symmetrise=true") != std::string::npos &&
      !problem.used_row_sums.ok())
    std::printf("symmetrised  %s\n",
                problem.used_row_sums.report(problem.scene(), problem.mesh).c_str());
  for (const std::string& note : problem.method->left_out())
    std::printf("left out     %s\n", note.c_str());
}

// CSV of the non-zero entries: i,j,F.
void write_entries_csv(const std::string& path, const FormFactorMatrix& m) {
  ensure_parent_folder(path);
  CsvWriter csv(path, {"i", "j", "F"});
  for (size_t i = 0; i < m.size(); ++i)
    for (size_t j = 0; j < m.size(); ++j)
      if (double f = m.at(i, j); f != 0.0) csv.add(i).add(j).add(f).end_row();
  csv.close();
  log::info("wrote " + path);
}

}  // namespace

void add_formfactors_command(CLI::App& app) {
  auto* command = app.add_subcommand("formfactors", "compute a form-factor matrix and check it");
  auto scene = std::make_shared<SceneOptions>();
  auto ff = std::make_shared<FormFactorOptions>();
  auto out = std::make_shared<std::string>();
  add_scene_options(*command, *scene);
  add_form_factor_options(*command, *ff, false);
  command->add_option("--out", *out, "CSV of the non-zero entries: i,j,F");
  auto sample = std::make_shared<SampleOptions>();
  command
      ->add_option("--sample-rows", sample->rows,
                   "compute and check only N rows drawn at random (for scenes too large to build "
                   "whole): their row sums against 1 + the method's stated error; no matrix, "
                   "no cache")
      ->check(CLI::PositiveNumber);
  command->add_option("--sample-seed", sample->seed, "seed of the rows --sample-rows draws");
  command->add_flag("--verify-cache", sample->verify_cache,
                    "with --sample-rows: compare the sampled rows, bit for bit, with this scene's "
                    "cached matrix (e.g. one merged from blocks); exit 3 naming the first "
                    "differing entry, or when the cache holds no such matrix");
  command->callback([scene, ff, out, sample]() {
    if (sample->verify_cache && sample->rows == 0)
      throw UsageError("formfactors: --verify-cache compares sampled rows: give --sample-rows N");
    if (sample->rows > 0) {
      if (!out->empty())
        throw UsageError("formfactors: --out writes the whole matrix; drop --sample-rows");
      check_sampled_rows(*scene, *ff, *sample);
      return;
    }
    if (!out->empty()) check_writable(*out);  // before the computation, not after it
    ProblemSpec spec = make_problem_spec(*scene, *ff);
    spec.need_reference = false;
    spec.require_emitter = false;
    auto problem = prepare_problem(spec);
    print_build(*problem);
    if (!out->empty()) write_entries_csv(*out, problem->matrix);
  });
}

}  // namespace radlab::cli
