// The Snakemake workflow (workflow/Snakefile, docs/workflow.md) end to end on a tiny experiment:
// prepare -> 3 shards -> merge gives the unsharded `radlab run`'s trace and summary (time columns
// aside), two workflows sharing one empty cache at once leave it whole, a deleted shard is
// recomputed alone (read from Snakemake's own job table), a shard killed mid-way resumes, an
// edited experiment reruns everything, an edited material reruns its preparation and every shard,
// a shard whose summary.csv was cut is redone alone, and a failing shard or preparation fails its
// job with radlab's message. Skipped, saying so, when snakemake is not installed
// (scripts/install-deps.sh installs it).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <thread>

#include "core/csv_reader.h"
#include "experiments/run/summary.h"
#include "experiments/run/trace.h"
#include "tests/experiment_fixtures.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

using Result = radlab::testing::CommandResult;

Result shell(const std::string& command) {
  return radlab::testing::run_command(command);
}

bool have_snakemake() {
  return shell("snakemake --version").code == 0;
}

// A test body's first line: without snakemake the workflow cannot be tested (GTEST_SKIP returns
// from the test, so this is a macro).
#define SKIP_WITHOUT_SNAKEMAKE()                                                           \
  if (!have_snakemake())                                                                   \
  GTEST_SKIP() << "snakemake is not installed (scripts/install-deps.sh installs Debian's " \
                  "snakemake): the workflow is not tested"

// Extra snakemake arguments from $RADLAB_WORKFLOW_ARGS: scripts/test-slurm.sh runs these tests
// through Slurm with "--profile workflow/profiles/slurm".
std::string extra_arguments() {
  const char* extra = std::getenv("RADLAB_WORKFLOW_ARGS");
  return extra ? std::string(" ") + extra : std::string();
}

// One workflow invocation in its own Snakemake folder, every path absolute; `timeout` turns a
// hang into a failure.
std::string snakemake(const std::string& work, const std::string& experiment, int shards,
                      const std::string& out, const std::string& cache,
                      const std::string& extra = "") {
  return "timeout 900 snakemake -s " + std::string(RADLAB_SOURCE_DIR) +
         "/workflow/Snakefile --cores 2 --directory " + work +
         " --config experiment=" + experiment + " shards=" + std::to_string(shards) +
         " out=" + out + " cache=" + cache + " radlab=" + std::string(RADLAB_BINARY) +
         " plots=false " + extra + extra_arguments();
}

// Snakemake's "Job stats" table (printed before it runs anything): rule -> job count.
std::map<std::string, int> job_counts(const std::string& output) {
  std::map<std::string, int> counts;
  const size_t start = output.find("Job stats:");
  if (start == std::string::npos) return counts;
  std::istringstream lines(output.substr(start));
  std::string line;
  std::getline(lines, line);  // "Job stats:"
  std::getline(lines, line);  // header
  std::getline(lines, line);  // dashes
  while (std::getline(lines, line)) {
    std::istringstream fields(line);
    std::string rule;
    int count = 0;
    if (!(fields >> rule >> count) || rule == "total") break;
    counts[rule] = count;
  }
  return counts;
}

// Jobs of `rule` in a job table (0 when it has none).
int jobs(const std::map<std::string, int>& table, const std::string& rule) {
  const auto it = table.find(rule);
  return it == table.end() ? 0 : it->second;
}

void expect_same_results(const std::string& sweep, const std::string& reference) {
  EXPECT_EQ(testing::without_columns(read_csv(sweep + "/trace.csv"), trace_time_columns()),
            testing::without_columns(read_csv(reference + "/trace.csv"), trace_time_columns()))
      << sweep;
  const CsvTable summary = read_csv(sweep + "/summary.csv");
  EXPECT_EQ(summary.rows.size(), 16u);  // 4 problems x 4 solver settings
  EXPECT_EQ(testing::without_columns(summary, summary_time_columns()),
            testing::without_columns(read_csv(reference + "/summary.csv"), summary_time_columns()))
      << sweep;
}

// `radlab prepare` on its own (no snakemake needed).
TEST(Prepare, FillsTheCacheThatRunThenLoads) {
  TempDir dir;
  const std::string tiny = std::string(RADLAB_SOURCE_DIR) + "/workflow/test/tiny.toml";
  const std::string env = "RADLAB_CACHE_DIR=" + dir.file("cache") + " ";
  const std::string radlab = env + RADLAB_BINARY;

  // The plan: every problem with its elements (cube 6 x 2^2 and 6 x 3^2 quads; Cornell box at
  // subdiv 3: 180, as `radlab scenes`), its estimates, and every run with its problem.
  const Result plan = shell(radlab + " -q prepare " + tiny + " --plan");
  ASSERT_EQ(plan.code, 0) << plan.output;
  for (const char* part : {"\"elements\": 24,", "\"elements\": 54,", "\"elements\": 180,",
                           "\"memory_mb\":", "\"prepare_seconds\":", "\"runs_total\": 16,",
                           "\"run_id\": \"shooting/scene:cornell/subdiv:3\""})
    EXPECT_NE(plan.output.find(part), std::string::npos) << part << "\n" << plan.output;
  EXPECT_FALSE(fs::exists(dir.file("cache")));  // --plan builds nothing

  // One problem, with its record naming the cache files it wrote.
  const Result one =
      shell(radlab + " prepare " + tiny + " --problem 3 --record " + dir.file("record/p3.json"));
  ASSERT_EQ(one.code, 0) << one.output;
  EXPECT_NE(one.output.find("[1/1] problem 3: scene:cornell/subdiv:3"), std::string::npos)
      << one.output;
  EXPECT_NE(one.output.find("prepared 1 of 1 problems"), std::string::npos) << one.output;
  std::ifstream record_file(dir.file("record/p3.json"));
  std::stringstream record;
  record << record_file.rdbuf();
  for (const char* part : {"\"index\": 3,", "\"elements\": 180,", ".ffm\"", ".ref\"",
                           "\"matrix_from_cache\": false", "certified"})
    EXPECT_NE(record.str().find(part), std::string::npos) << part << "\n" << record.str();

  // All problems; the one already prepared is loaded, not rebuilt; then `run` loads all four.
  const Result all = shell(radlab + " prepare " + tiny);
  ASSERT_EQ(all.code, 0) << all.output;
  EXPECT_NE(all.output.find("prepared 4 of 4 problems"), std::string::npos) << all.output;
  const size_t first_load = all.output.find("loaded from the cache");
  EXPECT_NE(first_load, std::string::npos) << all.output;
  EXPECT_EQ(all.output.find("loaded from the cache", first_load + 1), std::string::npos)
      << all.output;
  const Result run = shell(radlab + " run " + tiny + " --out " + dir.file("run"));
  ASSERT_EQ(run.code, 0) << run.output;
  size_t loaded = 0;
  for (size_t at = run.output.find("loaded from the cache"); at != std::string::npos;
       at = run.output.find("loaded from the cache", at + 1))
    ++loaded;
  EXPECT_EQ(loaded, 4u) << run.output;

  // Usage and input errors: a problem index out of range (2), a scene that does not load (3,
  // and no record claims it was prepared).
  const Result range = shell(radlab + " prepare " + tiny + " --problem 4");
  EXPECT_EQ(range.code, 2) << range.output;
  EXPECT_NE(range.output.find("has 4 problems (0 to 3)"), std::string::npos) << range.output;
  const std::string missing =
      dir.write("missing.toml",
                "scenes = [\"builtin:cube\", \"no_such_scene.obj\"]\nsolvers = [\"jacobi\"]\n"
                "[budget]\nrows = 10\n");
  const Result bad = shell(radlab + " prepare " + missing + " --record " + dir.file("bad.json"));
  EXPECT_EQ(bad.code, 3) << bad.output;
  EXPECT_NE(bad.output.find("prepared 1 of 2 problems"), std::string::npos) << bad.output;
  EXPECT_NE(bad.output.find("no_such_scene.obj: no such file"), std::string::npos) << bad.output;
  EXPECT_FALSE(fs::exists(dir.file("bad.json")));
  const Result help = shell(std::string(RADLAB_BINARY) + " prepare --help");
  EXPECT_EQ(help.code, 0) << help.output;
  EXPECT_NE(help.output.find("--plan"), std::string::npos) << help.output;
}

TEST(Workflow, ShardedEqualsUnshardedAndRedoesOnlyWhatIsMissing) {
  SKIP_WITHOUT_SNAKEMAKE();
  TempDir dir;
  // A copy, so that touching it (below) leaves the source tree alone.
  const std::string experiment = dir.file("tiny.toml");
  fs::copy_file(std::string(RADLAB_SOURCE_DIR) + "/workflow/test/tiny.toml", experiment);
  const std::string cache = dir.file("cache");

  // Two workflows at once on one empty cache: every matrix and reference is written by two
  // processes concurrently (the cache writes a private temporary file and renames it).
  const Result both =
      shell(snakemake(dir.file("a"), experiment, 3, dir.file("a/out"), cache) + " > " +
            dir.file("a.log") + " 2>&1 & a=$!; " +
            snakemake(dir.file("b"), experiment, 3, dir.file("b/out"), cache) + " > " +
            dir.file("b.log") + " 2>&1 & b=$!; wait $a; ra=$?; wait $b; " + "rb=$?; cat " +
            dir.file("a.log") + " " + dir.file("b.log") + "; exit $((ra | rb))");
  ASSERT_EQ(both.code, 0) << both.output;
  const std::map<std::string, int> first = job_counts(both.output);
  EXPECT_EQ(jobs(first, "prepare"), 4) << both.output;  // 2 scenes x 2 meshes
  EXPECT_EQ(jobs(first, "shard"), 3) << both.output;
  EXPECT_EQ(jobs(first, "merge"), 1) << both.output;

  // The unsharded sweep, on the cache the workflows filled.
  const Result single = shell("RADLAB_CACHE_DIR=" + cache + " " + RADLAB_BINARY + " -q run " +
                              experiment + " --out " + dir.file("single"));
  ASSERT_EQ(single.code, 0) << single.output;
  const std::string a = dir.file("a/out/workflow_tiny");
  expect_same_results(a + "/merged", dir.file("single"));
  expect_same_results(dir.file("b/out/workflow_tiny/merged"), dir.file("single"));
  // One matrix and one reference per problem, no temporary file left behind.
  std::map<std::string, int> cache_files;
  for (const auto& entry : fs::directory_iterator(cache))
    ++cache_files[entry.path().filename().string().find(".tmp") != std::string::npos
                      ? "tmp"
                      : entry.path().extension().string()];
  EXPECT_EQ(cache_files[".ffm"], 4);
  EXPECT_EQ(cache_files[".ref"], 4);
  EXPECT_EQ(cache_files["tmp"], 0);

  // Nothing to do when complete.
  const Result again = shell(snakemake(dir.file("a"), experiment, 3, dir.file("a/out"), cache));
  ASSERT_EQ(again.code, 0) << again.output;
  EXPECT_NE(again.output.find("Nothing to be done"), std::string::npos) << again.output;

  // A lost shard (a killed node): only it is recomputed, then the merge.
  const auto shard0_time = fs::last_write_time(a + "/shards/0/summary.csv");
  fs::remove_all(a + "/shards/1");
  const Result redo = shell(snakemake(dir.file("a"), experiment, 3, dir.file("a/out"), cache));
  ASSERT_EQ(redo.code, 0) << redo.output;
  const std::map<std::string, int> redone = job_counts(redo.output);
  EXPECT_EQ(jobs(redone, "prepare"), 0) << redo.output;
  EXPECT_EQ(jobs(redone, "shard"), 1) << redo.output;
  EXPECT_NE(redo.output.find("wildcards: i=1"), std::string::npos) << redo.output;
  EXPECT_EQ(jobs(redone, "merge"), 1) << redo.output;
  EXPECT_EQ(fs::last_write_time(a + "/shards/0/summary.csv"), shard0_time);
  expect_same_results(a + "/merged", dir.file("single"));

  // An edited experiment reruns everything that reads it (a dry run lists the jobs).
  std::ofstream(experiment, std::ios::app) << "# edited\n";
  const Result edited =
      shell(snakemake(dir.file("a"), experiment, 3, dir.file("a/out"), cache, "--dry-run"));
  ASSERT_EQ(edited.code, 0) << edited.output;
  const std::map<std::string, int> rerun = job_counts(edited.output);
  EXPECT_EQ(jobs(rerun, "prepare"), 4) << edited.output;
  EXPECT_EQ(jobs(rerun, "shard"), 3) << edited.output;
}

TEST(Workflow, AKilledShardResumesWhatItFinished) {
  SKIP_WITHOUT_SNAKEMAKE();
  TempDir dir;
  // Six runs of ~0.4 s each (jacobi on a 216-element cube, 300k rows), so a kill lands mid-shard.
  const std::string toml =
      dir.write("slow.toml",
                "name = \"slow\"\nscenes = [\"builtin:cube:rho=0.9\"]\n"
                "subdiv = 6\nsolvers = [\"jacobi\"]\n[form_factors]\nrays = 4\n"
                "[budget]\nrows = 300000\n[parameters.jacobi]\n"
                "omega = [1.0, 0.9, 0.8, 0.7, 0.6, 0.5]\n");
  const std::string cache = dir.file("cache");
  const Result prepared =
      shell("RADLAB_CACHE_DIR=" + cache + " " + RADLAB_BINARY + " -q prepare " + toml);
  ASSERT_EQ(prepared.code, 0) << prepared.output;

  // Shard 1 of 2 (runs 1, 3, 5) where the workflow keeps it, killed once run 1 is complete.
  const std::string shard = dir.file("out/slow/shards/1");
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    setenv("RADLAB_CACHE_DIR", cache.c_str(), 1);
    const int null = ::open("/dev/null", O_WRONLY);
    dup2(null, 1);
    dup2(null, 2);
    execl(RADLAB_BINARY, RADLAB_BINARY, "run", toml.c_str(), "--shard", "1/2", "--out",
          shard.c_str(), nullptr);
    _exit(127);
  }
  const std::string first_done = shard + "/.radlab-partial/000001.summary.csv";
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!fs::exists(first_done) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  kill(child, SIGKILL);
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the shard finished before it could be killed";

  // The workflow keeps the killed shard's folder: radlab resumes it, and says so in the log.
  const Result resumed = shell(snakemake(dir.file("w"), toml, 2, dir.file("out"), cache));
  ASSERT_EQ(resumed.code, 0) << resumed.output;
  EXPECT_EQ(jobs(job_counts(resumed.output), "shard"), 2) << resumed.output;
  std::ifstream log(dir.file("out/slow/logs/shard_1.log"));
  std::stringstream text;
  text << log.rdbuf();
  // Run 1 was complete at the kill; run 3 may have finished too if this process was slow to
  // wake (a loaded machine), but not run 5 as well, or the shard would not have been killed.
  const std::regex resumed_runs("resumed: ([12]) runs were already complete");
  EXPECT_TRUE(std::regex_search(text.str(), resumed_runs)) << text.str();
  EXPECT_EQ(read_csv(dir.file("out/slow/merged/summary.csv")).rows.size(), 6u);
}

TEST(Workflow, AnEditedMaterialOrACutShardRedoesTheShards) {
  // Defects (issue 36.2, 36.5): box.mtl edited after a complete workflow, and the workflow said
  // "Nothing to be done"; a shard's summary.csv cut, and every rerun failed in the merge.
  SKIP_WITHOUT_SNAKEMAKE();
  TempDir dir;
  dir.write("box.obj", testing::kBoxObj);
  dir.write("box.mtl", testing::kBoxMtl);
  const std::string toml = dir.write("box.toml", R"(name = "box"
scenes = ["box.obj", "builtin:cube:rho=0.7"]
subdiv = 2
solvers = ["gauss-seidel", "jacobi"]
[form_factors]
rays = 4
[budget]
rows = 200
)");
  const std::string cache = dir.file("cache");
  const std::string out = dir.file("out/box");
  const Result first = shell(snakemake(dir.file("w"), toml, 2, dir.file("out"), cache));
  ASSERT_EQ(first.code, 0) << first.output;

  // A cut summary.csv (its last row gone): that shard is redone, then the merge, which holds
  // every run again.
  std::string summary;
  {
    std::ifstream in(out + "/shards/0/summary.csv", std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    summary = text.str();
  }
  summary.erase(summary.rfind('\n', summary.size() - 2) + 1);
  std::ofstream(out + "/shards/0/summary.csv", std::ios::binary) << summary;
  const auto shard1_time = fs::last_write_time(out + "/shards/1/summary.csv");
  const Result cut = shell(snakemake(dir.file("w"), toml, 2, dir.file("out"), cache));
  ASSERT_EQ(cut.code, 0) << cut.output;
  EXPECT_NE(cut.output.find("shard 0: "), std::string::npos) << cut.output;
  EXPECT_NE(cut.output.find("the shard is redone"), std::string::npos) << cut.output;
  const std::map<std::string, int> redone = job_counts(cut.output);
  EXPECT_EQ(jobs(redone, "shard"), 1) << cut.output;
  EXPECT_EQ(jobs(redone, "merge"), 1) << cut.output;
  EXPECT_EQ(fs::last_write_time(out + "/shards/1/summary.csv"), shard1_time);
  EXPECT_EQ(read_csv(out + "/merged/summary.csv").rows.size(), 4u);

  // An edited material: the box's preparation and every shard rerun (each shard's identity
  // covers every scene file), then the merge.
  std::string mtl = testing::kBoxMtl;
  mtl.replace(mtl.find("Kd 0.5 0.5 0.5"), 14, "Kd 0.8 0.8 0.8");
  std::ofstream(dir.file("box.mtl"), std::ios::binary) << mtl;
  const Result edited = shell(snakemake(dir.file("w"), toml, 2, dir.file("out"), cache));
  ASSERT_EQ(edited.code, 0) << edited.output;
  const std::map<std::string, int> rerun = job_counts(edited.output);
  EXPECT_EQ(jobs(rerun, "prepare"), 1) << edited.output;  // the box's problem, not the cube's
  EXPECT_EQ(jobs(rerun, "shard"), 2) << edited.output;
  EXPECT_EQ(jobs(rerun, "merge"), 1) << edited.output;
  std::ifstream merged(out + "/merged/sweep.json");
  std::stringstream merged_text;
  merged_text << merged.rdbuf();
  const Result sha = shell("sha256sum " + dir.file("box.mtl"));
  ASSERT_EQ(sha.code, 0);
  EXPECT_NE(merged_text.str().find(sha.output.substr(0, 64)), std::string::npos)
      << merged_text.str();
}

TEST(Workflow, FailuresFailTheirJobWithRadlabsMessage) {
  SKIP_WITHOUT_SNAKEMAKE();
  TempDir dir;
  // A tolerance below the float storage floor (~8e-9 of max B*; above the reference's own,
  // ~1.6e-15, which would be refused): every run stagnates, a numerical failure (exit 4).
  const std::string stiff = dir.write("stiff.toml",
                                      "name = \"stiff\"\nscenes = [\"builtin:cube\"]\nsubdiv = 2\n"
                                      "solvers = [\"gauss-seidel\", \"jacobi\"]\n"
                                      "[form_factors]\nrays = 4\n[budget]\ntol = 1e-12\n");
  const Result failed =
      shell(snakemake(dir.file("w"), stiff, 2, dir.file("out"), dir.file("cache")));
  EXPECT_NE(failed.code, 0) << failed.output;
  EXPECT_NE(failed.output.find("Error in rule shard"), std::string::npos) << failed.output;
  EXPECT_NE(failed.output.find("radlab failed (exit 4)"), std::string::npos) << failed.output;
  EXPECT_NE(failed.output.find("stagnated at certified relative bound"), std::string::npos)
      << failed.output;
  // The log keeps radlab's message; the failed shard's folder is gone, so nothing merges it.
  std::ifstream log(dir.file("out/stiff/logs/shard_0.log"));
  std::stringstream text;
  text << log.rdbuf();
  EXPECT_NE(text.str().find("radlab: error: 1 of 1 runs failed"), std::string::npos) << text.str();
  EXPECT_FALSE(fs::exists(dir.file("out/stiff/shards/0/summary.csv")));
  EXPECT_FALSE(fs::exists(dir.file("out/stiff/merged")));

  // A scene that cannot be loaded fails its preparation (exit 3), naming the file.
  const std::string missing =
      dir.write("missing.toml",
                "name = \"missing\"\nscenes = [\"no_such_scene.obj\"]\nsolvers = [\"jacobi\"]\n"
                "[budget]\nrows = 10\n");
  const Result unprepared =
      shell(snakemake(dir.file("m"), missing, 1, dir.file("out"), dir.file("cache")));
  EXPECT_NE(unprepared.code, 0) << unprepared.output;
  EXPECT_NE(unprepared.output.find("Error in rule prepare"), std::string::npos)
      << unprepared.output;
  EXPECT_NE(unprepared.output.find("radlab failed (exit 3)"), std::string::npos)
      << unprepared.output;
  EXPECT_NE(unprepared.output.find("no_such_scene.obj: no such file"), std::string::npos)
      << unprepared.output;
}

// The bytes of `file` from `offset` on.
std::string bytes_from(const std::string& file, size_t offset) {
  std::ifstream in(file, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  const std::string bytes = text.str();
  return bytes.size() > offset ? bytes.substr(offset) : std::string();
}

// config blocks=3: the problem's matrix in 3 block jobs and a merge (the prepare job), whose
// cached matrix has the one-process build's key and payload (byte 128 on: the header before it
// records the build's time and ray count, tests/cli/prepare_blocks_test.cpp), and the sweep's
// results are the unsharded run's; a lost block record reruns that block alone.
TEST(Workflow, BlocksMergeIntoTheOneProcessMatrix) {
  SKIP_WITHOUT_SNAKEMAKE();
  TempDir dir;
  const std::string experiment = std::string(RADLAB_SOURCE_DIR) + "/workflow/test/blocks.toml";
  const std::string cache = dir.file("cache"), out = dir.file("out");
  const Result plan = shell(
      snakemake(dir.file("w"), experiment, 2, out, cache, "blocks=3 --dry-run --printshellcmds"));
  ASSERT_EQ(plan.code, 0) << plan.output;
  const std::map<std::string, int> planned = job_counts(plan.output);
  EXPECT_EQ(jobs(planned, "block"), 3) << plan.output;
  EXPECT_EQ(jobs(planned, "prepare"), 1) << plan.output;
  EXPECT_EQ(jobs(planned, "shard"), 2) << plan.output;
  for (const char* command : {"--block 1/3", "--block 3/3", "--merge-blocks 3"})
    EXPECT_NE(plan.output.find(command), std::string::npos) << command << "\n" << plan.output;

  const Result run = shell(snakemake(dir.file("w"), experiment, 2, out, cache, "blocks=3"));
  ASSERT_EQ(run.code, 0) << run.output;
  std::map<std::string, int> cache_files;
  std::string matrix;
  for (const auto& entry : fs::directory_iterator(cache)) {
    ++cache_files[entry.path().extension().string()];
    if (entry.path().extension() == ".ffm") matrix = entry.path().string();
  }
  EXPECT_EQ(cache_files[".ffb"], 3);
  EXPECT_EQ(cache_files[".ffm"], 1);

  // The one-process build of the same matrix, and the unsharded sweep on it.
  const std::string single = dir.file("single");
  const Result one = shell("RADLAB_CACHE_DIR=" + single + " " + RADLAB_BINARY + " -q run " +
                           experiment + " --out " + dir.file("unsharded"));
  ASSERT_EQ(one.code, 0) << one.output;
  const std::string single_matrix = single + "/" + fs::path(matrix).filename().string();
  ASSERT_TRUE(fs::exists(single_matrix)) << single_matrix;
  EXPECT_TRUE(bytes_from(matrix, 128) == bytes_from(single_matrix, 128))
      << matrix << " holds another matrix than " << single_matrix;
  const std::string merged = out + "/workflow_blocks/merged";
  EXPECT_EQ(testing::without_columns(read_csv(merged + "/summary.csv"), summary_time_columns()),
            testing::without_columns(read_csv(dir.file("unsharded") + "/summary.csv"),
                                     summary_time_columns()));

  // A lost block record: that block is redone alone, then the merge and what follows.
  fs::remove(out + "/workflow_blocks/prepare/blocks/problem_0_block_2.json");
  const Result redo =
      shell(snakemake(dir.file("w"), experiment, 2, out, cache, "blocks=3 --dry-run"));
  ASSERT_EQ(redo.code, 0) << redo.output;
  const std::map<std::string, int> again = job_counts(redo.output);
  EXPECT_EQ(jobs(again, "block"), 1) << redo.output;
  EXPECT_EQ(jobs(again, "prepare"), 1) << redo.output;
}

// config radlab_options: global radlab options (--limits for a scene above the defaults) reach
// the plan, read when the workflow is parsed, and every job's command.
TEST(Workflow, RadlabOptionsReachThePlanAndEveryJob) {
  SKIP_WITHOUT_SNAKEMAKE();
  TempDir dir;
  const std::string experiment = std::string(RADLAB_SOURCE_DIR) + "/workflow/test/blocks.toml";
  const std::string cache = dir.file("cache"), out = dir.file("out");
  const Result plan = shell(snakemake(dir.file("w"), experiment, 2, out, cache,
                                      "blocks=3 'radlab_options=--limits memory_gb=3' "
                                      "--dry-run --printshellcmds"));
  ASSERT_EQ(plan.code, 0) << plan.output;
  for (const char* command : {"--block 1/3", "--block 3/3", "--merge-blocks 3", "--shard 1/2"}) {
    const size_t at = plan.output.find(command);
    ASSERT_NE(at, std::string::npos) << command << "\n" << plan.output;
    const size_t line = plan.output.rfind('\n', at);
    EXPECT_NE(plan.output.substr(line, at - line).find("--limits memory_gb=3"), std::string::npos)
        << command << " runs without the options:\n"
        << plan.output;
  }
  // The plan honours them: this experiment plans 2 runs, above a limit of 1 run.
  const Result refused = shell(snakemake(dir.file("w"), experiment, 2, out, cache,
                                         "'radlab_options=--limits runs=1' --dry-run"));
  EXPECT_NE(refused.code, 0) << refused.output;
  EXPECT_NE(refused.output.find("runs"), std::string::npos) << refused.output;
  EXPECT_FALSE(fs::exists(out)) << "a refused plan wrote results";
}

}  // namespace
}  // namespace radlab
