// `radlab prepare EXPERIMENT.toml [--problem K] [--record FILE] [--plan]`: fills the cache with
// what the experiment's runs share, before any run starts.
//
// A sweep's runs share one form-factor matrix and one certified reference per scene x mesh x
// form-factor method (x seed): its "problems" (experiment_spec.h plan_sweep). `radlab run`
// prepares a problem when its first run needs it, so N shards started at once on an empty cache
// would each build the same matrix. `prepare` builds them once, up front, through the same code
// and the same cache as `run` (problem.h prepare_problem; $RADLAB_CACHE_DIR or ~/.cache/radlab),
// so a shard afterwards only loads. The workflow (workflow/Snakefile) runs one `prepare --problem
// K` per problem, then the shards.
//
// Blocked builds (formfactor/matrix/matrix_blocks.h; issue 33): `--problem K --block I/B` computes
// block I of B of problem K's form-factor matrix (its pairs split in B shares of equal estimated
// work for raycast, of equal pair counts for exact, each pair once; its rows for the hemicube) into
// the cache as a block file, independent of the other blocks (a Slurm node each); `--merge-blocks
// B` checks all B (present, this matrix's, this split's, intact) and merges them into the cached
// matrix, the one-process build's bits, then prepares as usual (the reference). `--plan --blocks B`
// adds each block's and the merge's estimates. The workflow runs them with config blocks=B.
//
// --plan builds no matrix: it loads each scene and meshes it, and prints as JSON the problems
// and runs with rough estimates of memory and time (below) that the workflow turns into
// scheduler resources. --record FILE writes, once every selected problem is prepared, a JSON
// record naming the cache files (written to a temporary name and renamed, so a record exists
// only for a finished preparation).
//
// Estimates (upper-bound-minded, machine-dependent, for a scheduler's requests, not for papers):
//   memory  what prepare_problem holds at its peak (experiments/problem/preparation_estimate.h,
//           the estimate the memory_gb limit checks too): the matrix in double (8n^2), its float
//           rounding (4n^2, float rows), the reference's LU (8n^2), the method's working memory
//           (hemicube: 8 bytes per pixel of its 3R^2 per thread, 48R^2 of weights), the program,
//           scene and mesh (64 MB + 4 kB per element); a shard that finds the cache empty
//           recomputes both, so shards are given the same figure.
//   time    prepare: 1 s to start + n^2 pairs at 1 us each (raycast; hemicube: n rows of 3R^2
//           pixels at 20 ns and n elements at 1 us) + n^3/3 LU flops at 1 ns (wall clock).
//           A run: (rows x n + checkpoints x n^2) x channels multiply-adds at 1 ns,
//           plus the budget's seconds; rows is the budget's rows or steps (a step reads about
//           one row), or 1000 sweeps (the runner's cap) under a tolerance alone.
//   Two levels (P patches): P x n patch rows (and their float rounding) instead of the matrix,
//           the P x P reduced LU; P (centre) or n (mean) rows at n us each + P^3/3 ns.
//   The workflow multiplies the times by a configurable safety factor.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>

#include "cli/cli_common.h"
#include "core/error.h"
#include "core/json.h"
#include "core/log.h"
#include "experiments/problem/preparation_estimate.h"
#include "experiments/sweep/experiment_spec.h"
#include "experiments/sweep/sweep.h"
#include "formfactor/matrix/matrix_blocks.h"
#include "formfactor/matrix/matrix_cache.h"
#include "scene/scene_loader.h"

namespace radlab::cli {
namespace {

// One block of a blocked build, or the merge (index 0), estimated.
struct BlockEstimate {
  size_t index = 0, first_row = 0, end_row = 0;
  size_t pairs = 0;         // unordered pairs (blocks of pairs) or entries (blocks of rows)
  uint64_t work = 0;        // its share of the estimated work (blocks of pairs cut by it)
  double facing_pairs = 0;  // its estimated facing pairs (the pairs that can hold entries)
  double memory_bytes = 0, seconds = 0;
};

struct ProblemEstimate {
  size_t elements = 0;
  int channels = 0;
  double matrix_bytes = 0, memory_bytes = 0, prepare_seconds = 0;
  std::string error;                     // the scene could not be loaded or meshed
  std::vector<std::string> scene_files;  // every file the scene reads (the workflow's inputs)
  // --blocks B: the blocks (min(B, the most the split allows) of them; none when the problem is
  // not built in blocks, `blocks_note` says why), their split ("pairs" or "rows") and the merge.
  std::vector<BlockEstimate> blocks;
  std::string split;
  BlockEstimate merge;
  std::string blocks_note;
  std::string work_unit;  // the estimated work's unit, when the split is cut by it
  uint64_t work_total = 0;
};

// The blocks of a problem's matrix and their merge (experiments/problem/preparation_estimate.h).
void estimate_blocks(const PlannedProblem& planned, const FormFactorMethod& method,
                     size_t requested, ProblemEstimate& e) {
  if (planned.spec.patches.two_level()) {
    e.blocks_note = "two levels: no n x n matrix";
    return;
  }
  if (!method.builds_in_row_blocks() && !method.builds_in_pair_blocks()) {
    e.blocks_note = "form factors '" + planned.spec.ff_method + "' are not built in blocks";
    return;
  }
  const BlockSplit split = block_split(method, planned.spec.ff_method);
  e.split = split == BlockSplit::kPairs ? "pairs" : "rows";
  const size_t count =
      std::min(requested, split == BlockSplit::kPairs ? e.elements / 2 : e.elements);
  // The split every block and the merge compute: blocks of pairs cut by the method's work.
  std::optional<PairWorkSplit> work;
  if (split == BlockSplit::kPairs) {
    work = pair_work_split(method, e.elements);
    e.work_unit = work->unit;
    e.work_total = work->total();
  }
  const PairWorkSplit* cut = work ? &*work : nullptr;
  for (const MatrixBlock& block : matrix_blocks(e.elements, count, split, cut)) {
    const PreparationEstimate b =
        estimate_matrix_block(planned.spec, e.elements, block, preparation_threads(), cut);
    e.blocks.push_back({block.index, block.first, block.end, block.pairs(), block.work,
                        block.facing_pairs, b.total_bytes(), b.seconds});
  }
  const PreparationEstimate m =
      estimate_block_merge(planned.spec, e.elements, preparation_threads(), cut);
  e.merge = {0, 0, e.elements, 0, 0, 0, m.total_bytes(), m.seconds};
}

ProblemEstimate estimate_problem(const PlannedProblem& planned, size_t blocks) {
  ProblemEstimate e;
  double patches = 0;
  e.memory_bytes = 256e6;  // the program alone; a problem that fails to load needs no more
  try {
    // With blocks, the method too (whether it builds in blocks).
    std::unique_ptr<Problem> problem;
    LoadedScene loaded;
    Mesh mesh;
    if (blocks > 0) problem = prepare_method(planned.spec);
    if (!problem) loaded = load_scene(planned.spec.scene);
    const Scene& scene = problem ? problem->scene() : loaded.scene;
    if (!problem) mesh = build_mesh(loaded.scene, planned.spec.mesh);
    const Mesh& meshed = problem ? problem->mesh : mesh;
    for (const SourceFile& f : scene.sources) e.scene_files.push_back(f.path);
    e.elements = meshed.size();
    e.channels = scene.is_grey() ? 1 : 3;
    if (planned.spec.patches.two_level())
      patches = double(make_patches(scene, meshed, planned.spec.patches).size());
    if (problem) estimate_blocks(planned, *problem->method, blocks, e);
  } catch (const Error& error) {
    e.error = error.what();
    return e;
  }
  const double n = double(e.elements);
  if (patches > 0) {  // two levels (docs/solvers.md): P x n patch rows, no n x n matrix
    const bool float_rows = planned.spec.precision == Precision::kFloat;
    const bool centre = planned.spec.patches.resolved_rows(planned.spec.ff_method) == "centre";
    e.matrix_bytes = patches * n * (float_rows ? 4.0 + 8.0 : 8.0);
    e.memory_bytes = e.matrix_bytes + 8.0 * patches * (patches + n) + 256e6;
    e.prepare_seconds =
        (centre ? patches : n) * n * 1e-6 + patches * patches * patches / 3.0 * 1e-9;
    return e;
  }
  // What prepare_problem holds at its peak (the matrix in double, its float rounding, the
  // reference's LU, the method's buffers: a hemicube's grow with R^2 per thread) and its time:
  // experiments/problem/preparation_estimate.h, the estimate the memory_gb limit checks.
  const PreparationEstimate estimate =
      estimate_preparation(planned.spec, e.elements, preparation_threads());
  e.matrix_bytes = estimate.matrix_bytes + estimate.float_bytes;
  e.memory_bytes = estimate.total_bytes();
  e.prepare_seconds = estimate.seconds;
  return e;
}

// Rough seconds of one run (see the file comment).
double estimate_run_seconds(const ExperimentSpec& spec, const ProblemEstimate& p) {
  const double n = double(p.elements);
  if (n == 0) return 0.0;
  const Budget& b = spec.budget;
  double rows = b.rows ? double(*b.rows) : b.steps ? double(*b.steps) : 1000.0 * n;
  if (b.empty()) rows = 3.0 * n;  // the runner's default: three sweeps' worth of steps
  const double growth = std::max(spec.schedule.growth, 1.01);
  const double checkpoints = double(spec.schedule.every_step_until) + 1.0 +
                             std::log(std::max(rows, 1.0)) / std::log(growth) +
                             double(spec.schedule.extra.size() + spec.images.steps.size()) + 16.0 +
                             std::min(rows / n, 1000.0);
  const double seconds = (rows * n + checkpoints * n * n) * double(p.channels) * 1e-9;
  return seconds + (b.seconds ? *b.seconds : 0.0);
}

void print_plan(const ExperimentSpec& spec, const SweepPlan& plan, size_t blocks) {
  std::vector<ProblemEstimate> estimates;
  for (size_t i = 0; i < plan.problems.size(); ++i) {
    log::info("[" + std::to_string(i + 1) + "/" + std::to_string(plan.problems.size()) +
              "] meshing " + plan.problems[i].label);
    estimates.push_back(estimate_problem(plan.problems[i], blocks));
  }
  JsonWriter json;
  json.begin_object();
  json.field("experiment", spec.path);
  json.field("name", spec.name);
  json.field("runs_total", plan.runs.size());
  json.key("problems").begin_array();
  for (size_t i = 0; i < plan.problems.size(); ++i) {
    const ProblemEstimate& e = estimates[i];
    json.begin_object();
    json.field("index", i);
    json.field("label", plan.problems[i].label);
    json.field("scene", plan.problems[i].spec.scene);
    json.field("elements", e.elements);
    json.field("channels", e.channels);
    json.field("matrix_bytes", e.matrix_bytes);
    json.field("memory_mb", std::ceil(e.memory_bytes / 1e6));
    json.field("prepare_seconds", e.prepare_seconds);
    json.field("scene_files", e.scene_files);
    if (blocks > 0) {
      if (!e.split.empty()) json.field("block_split", e.split);
      if (!e.work_unit.empty()) {
        json.field("block_work_unit", e.work_unit);
        json.field("block_work_total", e.work_total);
      }
      json.key("blocks").begin_array();
      for (const BlockEstimate& b : e.blocks) {
        json.begin_object();
        json.field("block", b.index);
        json.field("first_row", b.first_row);
        json.field("end_row", b.end_row);
        json.field(e.split == "pairs" ? "pairs" : "entries", b.pairs);
        if (!e.work_unit.empty()) {
          json.field("work", b.work);
          json.field("facing_pairs", std::round(b.facing_pairs));
        }
        json.field("memory_mb", std::ceil(b.memory_bytes / 1e6));
        json.field("seconds", b.seconds);
        json.end_object();
      }
      json.end_array();
      if (!e.blocks.empty()) {
        json.key("merge").begin_object();
        json.field("memory_mb", std::ceil(e.merge.memory_bytes / 1e6));
        json.field("seconds", e.merge.seconds);
        json.end_object();
      }
      if (!e.blocks_note.empty()) json.field("blocks_note", e.blocks_note);
    }
    if (!e.error.empty()) json.field("error", e.error);
    json.end_object();
  }
  json.end_array();
  json.key("runs").begin_array();
  for (const PlannedRun& run : plan.runs) {
    json.begin_object();
    json.field("index", run.index);
    json.field("problem", run.problem);
    json.field("run_id", run.run_id);
    json.field("seconds", estimate_run_seconds(spec, estimates[run.problem]));
    json.end_object();
  }
  json.end_array();
  json.end_object();
  std::printf("%s\n", json.str().c_str());
}

struct Prepared {
  size_t index = 0;
  std::string label, matrix_file, reference_file, reference;
  size_t elements = 0;
  bool matrix_from_cache = false;
  double seconds = 0;
};

// Writes `text` to `path` through a temporary sibling and a rename, so `path` is never partial.
void write_atomically(const std::string& path, const std::string& text) {
  ensure_parent_folder(path);
  const std::string temp = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream out(temp);
    out << text;
    out.close();
    if (!out) {
      std::error_code ignored;
      std::filesystem::remove(temp, ignored);
      throw InputError(path + ": cannot write file");
    }
  }
  std::error_code ec;
  std::filesystem::rename(temp, path, ec);
  if (ec) {
    std::filesystem::remove(temp, ec);
    throw InputError(path + ": cannot write file (" + ec.message() + ")");
  }
}

void write_record(const std::string& path, const ExperimentSpec& spec,
                  const std::vector<Prepared>& prepared) {
  JsonWriter json;
  json.begin_object();
  json.field("experiment", spec.path);
  json.field("name", spec.name);
  json.field("cache", default_cache_dir().string());
  json.key("problems").begin_array();
  for (const Prepared& p : prepared) {
    json.begin_object();
    json.field("index", p.index);
    json.field("label", p.label);
    json.field("elements", p.elements);
    json.field("matrix_file", p.matrix_file);
    json.field("matrix_from_cache", p.matrix_from_cache);
    json.field("reference_file", p.reference_file);
    json.field("reference", p.reference);
    json.field("seconds", p.seconds);
    json.end_object();
  }
  json.end_array();
  json.end_object();
  write_atomically(path, json.str() + "\n");
}

// `--block K/B`: block K of B of problem `index`'s matrix into the cache; with `record`, a JSON
// record of it (the workflow's block job output), written only once the block is stored.
void prepare_block(const ExperimentSpec& spec, const SweepPlan& plan, size_t index, size_t block,
                   size_t count, const std::string& record) {
  const PlannedProblem& planned = plan.problems[index];
  log::info("problem " + std::to_string(index) + ": " + planned.label + ", block " +
            std::to_string(block) + "/" + std::to_string(count));
  const auto start = std::chrono::steady_clock::now();
  MatrixBlock rows;
  const std::unique_ptr<Problem> problem = prepare_matrix_block(planned.spec, block, count, &rows);
  std::printf("%s of problem %zu in %s\n", rows.label().c_str(), index,
              problem->build.cache_file.c_str());
  if (record.empty()) return;
  JsonWriter json;
  json.begin_object();
  json.field("experiment", spec.path);
  json.field("name", spec.name);
  json.field("problem", index);
  json.field("label", planned.label);
  json.field("elements", problem->mesh.size());
  json.field("block", block);
  json.field("blocks", count);
  json.field("first_row", rows.first);
  json.field("end_row", rows.end);
  json.field("block_file", problem->build.cache_file);
  json.field("split", rows.split == BlockSplit::kPairs ? "pairs" : "rows");
  if (rows.total_work > 0) {
    json.field("work", rows.work);
    json.field("work_total", rows.total_work);
  }
  json.field("build", problem->build.summary());
  json.field("rays", problem->build.cost.rays);
  json.field("seconds",
             std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  json.end_object();
  write_atomically(record, json.str() + "\n");
}

}  // namespace

void add_prepare_command(CLI::App& app) {
  auto* command = app.add_subcommand(
      "prepare",
      "build an experiment's form-factor matrices and certified references into the cache, once "
      "per scene/mesh/method, before its runs (or shards) start");
  struct Options {
    std::string file, record, block;
    std::vector<size_t> problems;
    size_t merge_blocks = 0, blocks = 0;
    bool plan = false;
  };
  auto o = std::make_shared<Options>();
  command->add_option("experiment", o->file, "experiment file (experiments/*.toml)")->required();
  command->add_option("--problem", o->problems,
                      "prepare only problem K (0-based, as listed by --plan; repeatable)");
  command->add_option("--record", o->record,
                      "write a JSON record of the prepared problems and their cache files here "
                      "(only when all succeeded)");
  command->add_flag("--plan", o->plan,
                    "build nothing: print the problems and runs as JSON with estimates of memory "
                    "and time (for a scheduler)");
  command->add_option("--block", o->block,
                      "compute only block K of B of the problem's form-factor matrix (K/B: its "
                      "pairs split in B equal shares, or its rows for the hemicube) into the cache "
                      "as a block file; needs one problem "
                      "(--problem K); merge with --merge-blocks B");
  command
      ->add_option("--merge-blocks", o->merge_blocks,
                   "check the B blocks of each problem's matrix (--block K/B) and merge them "
                   "into the cached matrix, then prepare as usual (the reference)")
      ->check(CLI::PositiveNumber);
  command
      ->add_option("--blocks", o->blocks,
                   "with --plan: estimate each of B blocks of every problem's matrix")
      ->check(CLI::PositiveNumber);
  command->callback([o]() {
    if (!o->block.empty() && o->merge_blocks > 0)
      throw UsageError("--block and --merge-blocks: one at a time (blocks first, then the merge)");
    if ((!o->block.empty() || o->merge_blocks > 0) && o->plan)
      throw UsageError("--plan builds nothing: with blocks, use --plan --blocks B");
    if (o->blocks > 0 && !o->plan) throw UsageError("--blocks B goes with --plan");
    // Checked before the experiment is read: a malformed K/B is a usage error whatever the file.
    std::pair<size_t, size_t> block{0, 0};  // K, B; none when B is 0
    if (!o->block.empty()) block = parse_block_option(o->block, "--block");
    const ExperimentSpec spec = read_experiment(o->file);
    const SweepPlan plan = plan_sweep(spec);
    if (o->plan) {
      print_plan(spec, plan, o->blocks);
      return;
    }
    std::vector<size_t> selected = o->problems;
    if (selected.empty())
      for (size_t i = 0; i < plan.problems.size(); ++i) selected.push_back(i);
    for (size_t k : selected)
      if (k >= plan.problems.size())
        throw UsageError("--problem " + std::to_string(k) + ": " + spec.path + " has " +
                         std::to_string(plan.problems.size()) + " problems (0 to " +
                         std::to_string(plan.problems.size() - 1) + ")");
    log::info("cache: " + default_cache_dir().string());
    if (block.second > 0) {
      if (selected.size() != 1)
        throw UsageError("--block " + o->block + ": one problem at a time (--problem K; " +
                         spec.path + " has " + std::to_string(plan.problems.size()) + ")");
      prepare_block(spec, plan, selected[0], block.first, block.second, o->record);
      return;
    }
    if (o->merge_blocks > 0)
      for (size_t k : selected) {
        log::info("problem " + std::to_string(k) + ": merging " + std::to_string(o->merge_blocks) +
                  " blocks");
        merge_matrix_blocks(plan.problems[k].spec, o->merge_blocks);
      }

    std::vector<Prepared> prepared;
    std::vector<RunFailure> failures;  // one per problem that could not be prepared
    for (size_t k = 0; k < selected.size(); ++k) {
      const PlannedProblem& planned = plan.problems[selected[k]];
      log::info("[" + std::to_string(k + 1) + "/" + std::to_string(selected.size()) + "] problem " +
                std::to_string(selected[k]) + ": " + planned.label);
      const auto start = std::chrono::steady_clock::now();
      try {
        const std::unique_ptr<Problem> problem = prepare_problem(planned.spec);
        Prepared p;
        p.index = selected[k];
        p.label = planned.label;
        p.elements = problem->mesh.size();
        p.matrix_file = problem->matrix_cache_file;
        p.reference_file = problem->reference_cache_file;
        p.matrix_from_cache = problem->build.cached;
        p.reference = problem->reference ? problem->reference->summary() : "";
        p.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        prepared.push_back(std::move(p));
      } catch (const Error& e) {
        log::info("cannot prepare " + planned.label + ": " + e.what());
        failures.push_back({selected[k], planned.label, e.code(), e.what()});
      } catch (const std::bad_alloc&) {
        log::info("cannot prepare " + planned.label + ": out of memory");
        failures.push_back({selected[k], planned.label, ExitCode::kNumerical,
                            planned.label + ": out of memory (a coarser mesh needs less)"});
      }
    }
    std::printf("prepared %zu of %zu problems in %s\n", prepared.size(), selected.size(),
                default_cache_dir().string().c_str());
    if (!failures.empty()) {
      SweepReport report;
      report.failures = failures;
      std::string message = std::to_string(failures.size()) + " of " +
                            std::to_string(selected.size()) + " problems could not be prepared:";
      for (const RunFailure& f : failures) message += "\n  " + f.run_id + ": " + f.message;
      throw Error(ExitCode(report.exit_code()), message);
    }
    if (!o->record.empty()) write_record(o->record, spec, prepared);
  });
}

}  // namespace radlab::cli
