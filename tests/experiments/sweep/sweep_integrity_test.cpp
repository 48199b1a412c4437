// Nothing lost, nothing mixed (issue 12, items 1-4, 7, 10, 11): each test reproduces a defect
// found by the fault campaign — merges that mixed or dropped runs, half-written merges, stale and
// interleaved sweep folders, lost file endings with exit 0, crashes of the old JSON reader,
// "internal error" on unwritable folders, cache temporaries left forever and matrices built
// twice — and checks the fix. docs/reliability.md lists them.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "core/csv_reader.h"
#include "core/error.h"
#include "core/file_lock.h"
#include "core/json_reader.h"
#include "core/output_file.h"
#include "experiments/run/summary.h"
#include "experiments/run/trace.h"
#include "experiments/sweep/experiment_spec.h"
#include "experiments/sweep/merge.h"
#include "experiments/sweep/sweep.h"
#include "experiments/sweep/sweep_folder.h"
#include "formfactor/matrix/matrix_cache.h"
#include "tests/experiment_fixtures.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

namespace fs = std::filesystem;
using testing::expect_error;
using testing::TempDir;

// Two gauss-seidel runs on a 24-element cube; a few milliseconds each.
using radlab::testing::kTwoRuns;  // tests/experiment_fixtures.h

// The same with a third run, so a 3-way split is possible; and with images.
const char* kThreeRunsWithImages = R"(name = "tiny"
scenes = ["builtin:cube:rho=0.8"]
subdiv = 2
solvers = ["gauss-seidel", "jacobi"]
[form_factors]
rays = 4
[budget]
rows = 200
[parameters.gauss-seidel]
omega = [1.0, 1.3]
[images]
steps = [2]
width = 16
height = 16
)";

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

void replace_in_file(const std::string& path, const std::string& from, const std::string& to) {
  std::string text = read_text(path);
  const size_t at = text.find(from);
  ASSERT_NE(at, std::string::npos) << path << " lacks " << from;
  text.replace(at, from.size(), to);
  write_text(path, text);
}

std::vector<std::string> files_in(const std::string& folder) {
  std::vector<std::string> names;
  if (!fs::exists(folder)) return names;
  for (const auto& entry : fs::directory_iterator(folder))
    names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

// Recomputes a shard's manifest after an edit, as if the shard had been written that way: the
// checks the manifest stands in front of (repeated rows, rows of unknown runs) are tested alone.
void reseal(const std::string& folder) {
  Json sweep = read_json_file(folder + "/sweep.json");
  Json files = Json::array();
  for (const ManifestEntry& e : folder_manifest(folder))
    files.push_back({{"path", e.path}, {"sha256", e.sha256}, {"bytes", e.bytes}});
  sweep["files"] = files;
  write_text(folder + "/sweep.json", sweep.dump(2));
}

// Two shards of kTwoRuns in DIR/s0 and DIR/s1.
void run_two_shards(const TempDir& dir, const std::string& toml = kTwoRuns) {
  ExperimentSpec spec = read_experiment(dir.write("e.toml", toml));
  run_sweep(spec, {dir.file("s0"), 0, 2, "test"});
  run_sweep(spec, {dir.file("s1"), 1, 2, "test"});
}

// --- The command line -------------------------------------------------------------------------

using Result = radlab::testing::CommandResult;

// Runs `shell_command` under sh (so tests can set limits first); `timeout` turns a hang into a
// failure (exit 124).
Result shell(const std::string& shell_command) {
  return radlab::testing::run_command("timeout 120 sh -c '" + shell_command + "'");
}

// `radlab ARGUMENTS` with its own cache folder.
Result radlab(const TempDir& dir, const std::string& arguments, const std::string& prefix = "") {
  return shell(prefix + "RADLAB_CACHE_DIR=" + dir.file("cache") + " exec " +
               std::string(RADLAB_BINARY) + " " + arguments);
}

#define EXPECT_OUTPUT_HAS(result, text) \
  EXPECT_NE((result).output.find(text), std::string::npos) << (result).output

// === 1. merge records and checks what the shards are ==========================================

TEST(ReliabilityMerge, RefusesShardsOfAnEditedExperiment) {
  // Defect: shards of an edited experiment (subdiv 2 in one, 3 in the other) merged, exit 0.
  TempDir dir;
  ExperimentSpec spec = read_experiment(dir.write("e.toml", kTwoRuns));
  run_sweep(spec, {dir.file("s0"), 0, 2, "test"});
  std::string edited = kTwoRuns;
  edited.replace(edited.find("subdiv = 2"), 10, "subdiv = 3");
  ExperimentSpec spec2 = read_experiment(dir.write("e.toml", edited));
  run_sweep(spec2, {dir.file("s1"), 1, 2, "test"});
  expect_error<InputError>(
      [&] {
        merge_sweeps({dir.file("s0"), dir.file("s1")}, dir.file("m"));
      },
      {"experiment_digest", "edited"});
  EXPECT_FALSE(fs::exists(dir.file("m")));
}

TEST(ReliabilityMerge, RefusesShardsOfDifferentBuilds) {
  TempDir dir;
  run_two_shards(dir);
  for (const char* key : {"git_sha", "source_hash"}) {
    const std::string path = dir.file("s1/sweep.json");
    const std::string original = read_text(path);
    const std::string field = std::string("\"") + key + "\": \"";
    std::string text = original;
    text.insert(text.find(field) + field.size(), "0ther");
    write_text(path, text);
    expect_error<InputError>(
        [&] {
          merge_sweeps({dir.file("s0"), dir.file("s1")}, dir.file("m"));
        },
        {std::string("build.") + key, "different"});
    write_text(path, original);
  }
  EXPECT_EQ(merge_sweeps({dir.file("s0"), dir.file("s1")}, dir.file("m")), 2u);
}

TEST(ReliabilityMerge, RefusesAnIncompleteUnionUnlessAllowedAndThenSaysSo) {
  // Defect: one shard of two, or shards 0/2 + 1/3, merged with exit 0 into a sweep.json that
  // claimed a complete unsplit sweep.
  TempDir dir;
  ExperimentSpec spec = read_experiment(dir.write("e.toml", kThreeRunsWithImages));
  ASSERT_EQ(plan_sweep(spec).runs.size(), 3u);
  run_sweep(spec, {dir.file("s0"), 0, 2, "test"});
  run_sweep(spec, {dir.file("t1"), 1, 3, "test"});
  expect_error<InputError>([&] { merge_sweeps({dir.file("s0")}, dir.file("m")); },
                           {"2 of the 3 runs", "missing shards: 1/2", "--allow-incomplete"});
  expect_error<InputError>(
      [&] {
        merge_sweeps({dir.file("s0"), dir.file("t1")}, dir.file("m"));
      },
      {"3-way split", "2-way split"});
  EXPECT_FALSE(fs::exists(dir.file("m")));

  MergeOptions allow;
  allow.allow_incomplete = true;
  EXPECT_EQ(merge_shards({dir.file("s0")}, dir.file("m"), allow), 2u);
  const Json merged = read_json_file(dir.file("m/sweep.json"));
  EXPECT_EQ(merged["status"], "incomplete");
  EXPECT_EQ(merged["missing_runs"], 1);
  EXPECT_EQ(merged["missing_shards"][0], "1/2");
}

TEST(ReliabilityMerge, RefusesDuplicatedTraceRowsAndRowsOfUnknownRuns) {
  TempDir dir;
  run_two_shards(dir);
  const std::string trace = dir.file("s0/trace.csv");
  const std::string original = read_text(trace);
  const size_t second_line = original.find('\n') + 1;
  const std::string row =
      original.substr(second_line, original.find('\n', second_line) + 1 - second_line);
  write_text(trace, original + row);
  reseal(dir.file("s0"));
  expect_error<InputError>(
      [&] {
        merge_sweeps({dir.file("s0"), dir.file("s1")}, dir.file("m"));
      },
      {"trace.csv", "repeats run", "step"});
  std::string foreign = row;
  foreign.replace(0, foreign.find(','), "jacobi/scene:elsewhere");
  write_text(trace, original + foreign);
  reseal(dir.file("s0"));
  expect_error<InputError>(
      [&] {
        merge_sweeps({dir.file("s0"), dir.file("s1")}, dir.file("m"));
      },
      {"jacobi/scene:elsewhere", "not in"});
  EXPECT_FALSE(fs::exists(dir.file("m")));
}

TEST(ReliabilityMerge, RefusesAShardThatIsNotComplete) {
  TempDir dir;
  run_two_shards(dir);
  replace_in_file(dir.file("s1/sweep.json"), "\"status\": \"complete\"", "\"status\": \"running\"");
  expect_error<InputError>(
      [&] {
        merge_sweeps({dir.file("s0"), dir.file("s1")}, dir.file("m"));
      },
      {"s1/sweep.json", "status 'running'", "not complete"});
}

// === 2. merge validates first, writes a temporary sibling, never writes into a shard ===========

TEST(ReliabilityMerge, ARefusedMergeWritesNothing) {
  // Defect: summary.csv, trace.csv and runs/ were written before sweep.json was checked, so a
  // refused merge left a folder that looked valid.
  TempDir dir;
  run_two_shards(dir);
  replace_in_file(dir.file("s1/sweep.json"), "\"name\": \"tiny\"", "\"name\": \"other\"");
  expect_error<InputError>(
      [&] {
        merge_sweeps({dir.file("s0"), dir.file("s1")}, dir.file("m"));
      },
      {"name", "different experiments"});
  EXPECT_FALSE(fs::exists(dir.file("m")));
  // Nor a temporary sibling.
  for (const std::string& name : files_in(dir.path().string()))
    EXPECT_EQ(name.find("m.tmp"), std::string::npos) << name;
}

TEST(ReliabilityMerge, RefusesAnOutputFolderThatIsOrHoldsOrLiesInAShard) {
  // Defect: --out equal to a shard damaged the shard (exit 1).
  TempDir dir;
  run_two_shards(dir);
  const std::string before = read_text(dir.file("s0/summary.csv"));
  expect_error<UsageError>(
      [&] {
        merge_sweeps({dir.file("s0"), dir.file("s1")}, dir.file("s0"));
      },
      {"is the shard"});
  expect_error<UsageError>(
      [&] {
        merge_sweeps({dir.file("s0"), dir.file("s1")}, dir.file("s0/") + "/merged");
      },
      {"inside the shard"});
  expect_error<UsageError>(
      [&] {
        merge_sweeps({dir.file("s0"), dir.file("s1")}, dir.path().string());
      },
      {"lies inside --out"});
  EXPECT_EQ(read_text(dir.file("s0/summary.csv")), before);
  EXPECT_FALSE(fs::exists(dir.file("s0/merged")));
  // The command line says so with exit 2.
  Result r =
      radlab(dir, "merge " + dir.file("s0") + " " + dir.file("s1") + " --out " + dir.file("s1"));
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_OUTPUT_HAS(r, "is the shard");
}

TEST(ReliabilityMerge, ReplacesAPreviousMergeWhole) {
  // A second merge into the same folder leaves exactly the new result (no file of the old one).
  TempDir dir;
  run_two_shards(dir);
  EXPECT_EQ(merge_sweeps({dir.file("s0"), dir.file("s1")}, dir.file("m")), 2u);
  write_text(dir.file("m/runs/stale.run.json"), "{}");
  EXPECT_EQ(merge_sweeps({dir.file("s0"), dir.file("s1")}, dir.file("m")), 2u);
  EXPECT_FALSE(fs::exists(dir.file("m/runs/stale.run.json")));
  EXPECT_EQ(read_csv(dir.file("m/summary.csv")).rows.size(), 2u);
  // A folder that is not empty and holds no sweep is not replaced.
  fs::create_directories(dir.file("x"));
  write_text(dir.file("x/notes.txt"), "mine");
  expect_error<UsageError>(
      [&] {
        merge_sweeps({dir.file("s0"), dir.file("s1")}, dir.file("x"));
      },
      {"holds no sweep"});
  EXPECT_EQ(read_text(dir.file("x/notes.txt")), "mine");
}

// === 3. sweeps: status, lock, foreign folders, stale runs, resume =============================

TEST(ReliabilitySweep, RefusesAFolderOfAnotherExperimentWithoutOverwrite) {
  TempDir dir;
  ExperimentSpec tiny = read_experiment(dir.write("e.toml", kTwoRuns));
  std::string other_text = kTwoRuns;
  other_text.replace(other_text.find("tiny"), 4, "other");
  ExperimentSpec other = read_experiment(dir.write("o.toml", other_text));
  run_sweep(other, {dir.file("out"), 0, 1, "test"});
  expect_error<UsageError>(
      [&] {
        run_sweep(tiny, {dir.file("out"), 0, 1, "test"});
      },
      {"experiment 'other'", "--overwrite"});
  // Nothing of the other sweep was touched.
  EXPECT_EQ(read_json_file(dir.file("out/sweep.json"))["name"], "other");
  // A folder with files but no sweep is refused too; --overwrite removes only sweep files.
  fs::create_directories(dir.file("mine"));
  write_text(dir.file("mine/notes.txt"), "keep");
  expect_error<UsageError>(
      [&] {
        run_sweep(tiny, {dir.file("mine"), 0, 1, "test"});
      },
      {"no sweep.json"});
  SweepOptions overwrite{dir.file("out"), 0, 1, "test", true};
  run_sweep(tiny, overwrite);
  EXPECT_EQ(read_json_file(dir.file("out/sweep.json"))["name"], "tiny");
  overwrite.out_dir = dir.file("mine");
  run_sweep(tiny, overwrite);
  EXPECT_EQ(read_text(dir.file("mine/notes.txt")), "keep");
  // Another shard of the same experiment is refused too: it would replace the first.
  expect_error<UsageError>(
      [&] {
        run_sweep(tiny, {dir.file("out"), 1, 2, "test"});
      },
      {"shard 0/1", "its own --out"});
}

TEST(ReliabilitySweep, ASecondWriterOfOneFolderIsRefused) {
  // Defect: two processes with the same --out interleaved their summary rows (3 of 4 malformed),
  // both exit 0.
  TempDir dir;
  ExperimentSpec spec = read_experiment(dir.write("e.toml", kTwoRuns));
  fs::create_directories(dir.file("out"));
  auto held = FileLock::try_acquire(dir.file("out/.radlab.lock"));
  ASSERT_TRUE(held);
  expect_error<UsageError>(
      [&] {
        run_sweep(spec, {dir.file("out"), 0, 1, "test"});
      },
      {"another radlab process"});
  EXPECT_FALSE(fs::exists(dir.file("out/summary.csv")));
  held.reset();
  EXPECT_EQ(run_sweep(spec, {dir.file("out"), 0, 1, "test"}).runs_done, 2u);
}

TEST(ReliabilitySweep, ARerunOfAnEditedExperimentLeavesNoStaleRunsOrImages) {
  // Defect: a changed experiment re-run into the same folder kept the old runs and images, which
  // the contact sheet then showed.
  TempDir dir;
  ExperimentSpec three = read_experiment(dir.write("e.toml", kThreeRunsWithImages));
  run_sweep(three, {dir.file("out"), 0, 1, "test"});
  ASSERT_EQ(files_in(dir.file("out/runs")).size(), 6u);  // run.json + radiosity.csv each
  std::string edited = kThreeRunsWithImages;
  edited.replace(edited.find("\"gauss-seidel\", \"jacobi\""), 24, "\"gauss-seidel\"");
  ExperimentSpec two = read_experiment(dir.write("e.toml", edited));
  run_sweep(two, {dir.file("out"), 0, 1, "test"});
  EXPECT_EQ(files_in(dir.file("out/runs")).size(), 4u);
  for (const char* folder : {"out/runs", "out/images"})
    for (const std::string& name : files_in(dir.file(folder)))
      EXPECT_EQ(name.find("jacobi"), std::string::npos) << name;
  EXPECT_EQ(read_csv(dir.file("out/summary.csv")).rows.size(), 2u);
  EXPECT_EQ(read_json_file(dir.file("out/sweep.json"))["status"], "complete");
}

// Six runs of ~0.4 s each (jacobi on a 216-element cube, 300k rows), so a kill lands mid-sweep:
// three on each of two problems (runs 0-2 on rho=0.9, 3-5 on rho=0.85).
const char* kSixSlowRuns = R"(name = "slow"
scenes = ["builtin:cube:rho=0.9", "builtin:cube:rho=0.85"]
subdiv = 6
solvers = ["jacobi"]
[form_factors]
rays = 4
[budget]
rows = 300000
[parameters.jacobi]
omega = [1.0, 0.9, 0.8]
)";

TEST(ReliabilitySweep, AKilledSweepIsMarkedRunningAndResumes) {
  // Defect: sweep.json was written only at the end, so a kill -9 during a re-run left the old
  // sweep.json beside a partial trace.csv; and a re-run started from scratch.
  TempDir dir;
  const std::string toml = dir.write("slow.toml", kSixSlowRuns);
  const std::string out = dir.file("out");
  // A first, complete sweep: the kill below happens during a re-run over it.
  Result whole = radlab(dir, "-q run " + toml + " --out " + dir.file("whole"));
  ASSERT_EQ(whole.code, 0) << whole.output;
  fs::copy(dir.file("whole"), out, fs::copy_options::recursive);

  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    setenv("RADLAB_CACHE_DIR", dir.file("cache").c_str(), 1);
    const int null = ::open("/dev/null", O_WRONLY);
    dup2(null, 1);
    dup2(null, 2);
    execl(RADLAB_BINARY, RADLAB_BINARY, "run", toml.c_str(), "--out", out.c_str(), nullptr);
    _exit(127);
  }
  // Kill it once the first problem's three runs are complete (their summary rows wait in the
  // partial folder), so the resumed sweep never prepares that problem again.
  const std::string second_done = out + "/.radlab-partial/000002.summary.csv";
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!fs::exists(second_done) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  kill(child, SIGKILL);
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the sweep finished before it could be killed";

  // The folder says it is not complete, and holds no result that could pass for one.
  EXPECT_EQ(read_json_file(out + "/sweep.json")["status"], "running");
  EXPECT_FALSE(fs::exists(out + "/trace.csv"));
  EXPECT_FALSE(fs::exists(out + "/summary.csv"));
  if (std::system("/usr/bin/python3 -c 'import matplotlib, pandas' 2>/dev/null") == 0) {
    Result plot = shell("/usr/bin/python3 " + std::string(RADLAB_SOURCE_DIR) +
                        "/scripts/plot_traces.py " + out);
    EXPECT_NE(plot.code, 0) << plot.output;
    EXPECT_OUTPUT_HAS(plot, "not complete");
  }

  // The same command again resumes: the complete runs are skipped, and it says so.
  Result resumed = radlab(dir, "run " + toml + " --out " + out);
  ASSERT_EQ(resumed.code, 0) << resumed.output;
  EXPECT_OUTPUT_HAS(resumed, "already complete");
  EXPECT_OUTPUT_HAS(resumed, "resumed:");
  EXPECT_EQ(read_json_file(out + "/sweep.json")["status"], "complete");
  // The result is the uninterrupted one (times aside).
  CsvTable a = read_csv(out + "/trace.csv"), b = read_csv(dir.file("whole/trace.csv"));
  ASSERT_EQ(a.rows.size(), b.rows.size());
  for (const std::string& time : trace_time_columns()) {
    const size_t column = a.column(time);
    for (size_t r = 0; r < a.rows.size(); ++r) {
      a.rows[r][column].clear();
      b.rows[r][column].clear();
    }
  }
  EXPECT_EQ(a.rows, b.rows);
  EXPECT_EQ(read_csv(out + "/summary.csv").rows.size(), 6u);
  EXPECT_FALSE(fs::exists(out + "/.radlab-partial"));
  // sweep.json too: the same runs, failures and problems (the first problem's entry is rebuilt
  // from its runs' run.json).
  EXPECT_NE(resumed.output.find("omega:0.8: already complete"), std::string::npos)
      << resumed.output;
  const Json resumed_sweep = read_json_file(out + "/sweep.json");
  const Json whole_sweep = read_json_file(dir.file("whole/sweep.json"));
  for (const char* key : {"runs", "failed", "problems", "experiment_digest", "plan_digest"})
    EXPECT_EQ(resumed_sweep[key], whole_sweep[key]) << key;
}

TEST(ReliabilitySweep, PlotScriptsShowOnlyTheRunsSweepJsonLists) {
  if (std::system("/usr/bin/python3 -c 'import matplotlib, pandas' 2>/dev/null") != 0)
    GTEST_SKIP() << "python3-matplotlib/pandas not installed";
  TempDir dir;
  ExperimentSpec spec = read_experiment(dir.write("e.toml", kThreeRunsWithImages));
  run_sweep(spec, {dir.file("out"), 0, 1, "test"});
  // An image of a run the sweep does not list (e.g. copied in, or from an older sweep).
  fs::copy_file(dir.file("out/images/jacobi_scene_cube_rho_0.8_step000002.png"),
                dir.file("out/images/stale_run_step000002.png"));
  const std::string scripts = std::string(RADLAB_SOURCE_DIR) + "/scripts/";
  Result sheet = shell("/usr/bin/python3 " + scripts + "contact_sheet.py " + dir.file("out") +
                       " --out " + dir.file("sheet.png"));
  EXPECT_EQ(sheet.code, 0) << sheet.output;
  EXPECT_OUTPUT_HAS(sheet, "ignored images of 1 runs");
  replace_in_file(dir.file("out/sweep.json"), "\"status\": \"complete\"",
                  "\"status\": \"running\"");
  for (const char* script : {"contact_sheet.py", "plot_traces.py", "plot_coverage.py"}) {
    Result r = shell("/usr/bin/python3 " + scripts + script + " " + dir.file("out"));
    EXPECT_NE(r.code, 0) << script << ": " << r.output;
    EXPECT_OUTPUT_HAS(r, "not complete");
  }
}

// === 4. a failed write is an error, and leaves no file that looks complete ====================

TEST(ReliabilityOutputs, AFileSizeLimitJustUnderTheTraceIsAnErrorNotExit0) {
  // Defect: with a file-size limit just under trace.csv's size, the end of the file was lost in
  // the last flush, which nobody checked: 3 rows lost, exit 0.
  TempDir dir;
  const std::string solve =
      "solve builtin:cube:rho=0.8 --subdiv 2 --solver gauss-seidel --rows 400 --trace ";
  Result full = radlab(dir, solve + dir.file("full.csv"));
  ASSERT_EQ(full.code, 0) << full.output;
  const uintmax_t size = fs::file_size(dir.file("full.csv"));
  ASSERT_GT(size, 2048u);
  // Under sh (dash, or bash in POSIX mode) ulimit -f counts 512-byte blocks. The limit is under
  // the first run's size by 1 to 1.5 kB: far more than this run's trace can be shorter (its 33
  // rows differ only in the lengths of their time columns, a few bytes each; the size must not
  // decide whether the limit is crossed), and less than the stream's 8 kB buffer, so only the
  // final flush fails. SIGXFSZ ignored: write() then returns EFBIG, which is what must be noticed.
  const std::string limit =
      "trap \"\" XFSZ; ulimit -f " + std::to_string((size - 1024) / 512) + "; ";
  Result r = radlab(dir, solve + dir.file("cut.csv"), limit);
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_OUTPUT_HAS(r, "cut.csv");
  EXPECT_FALSE(fs::exists(dir.file("cut.csv")));
  for (const std::string& name : files_in(dir.path().string()))
    EXPECT_EQ(name.find(".tmp."), std::string::npos) << name;
}

TEST(ReliabilityOutputs, AFullDiskIsAnError) {
  // /dev/full: every write fails with ENOSPC. A device is written directly (nothing to rename).
  TempDir dir;
  Result r = radlab(dir,
                    "solve builtin:cube --subdiv 2 --solver gauss-seidel --steps 10 --out "
                    "/dev/full");
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_OUTPUT_HAS(r, "/dev/full");
  EXPECT_OUTPUT_HAS(r, "No space left on device");
}

TEST(ReliabilityOutputs, ASweepThatCannotWriteItsResultsFailsAndIsNotComplete) {
  TempDir dir;
  const std::string toml = dir.write("e.toml", kTwoRuns);
  Result whole = radlab(dir, "-q run " + toml + " --out " + dir.file("whole"));
  ASSERT_EQ(whole.code, 0) << whole.output;
  // The limit must let every file but trace.csv through and stop trace.csv, whatever the time
  // columns' lengths this run. trace.csv concatenates the two runs' partial traces (the same
  // number of rows each), so each partial is about half of it; three quarters of the whole
  // trace leaves a quarter of it (~11 kB) on either side for the time columns to vary in.
  const uintmax_t trace_size = fs::file_size(dir.file("whole/trace.csv"));
  for (const auto& entry : fs::recursive_directory_iterator(dir.file("whole"))) {
    if (entry.is_regular_file() && entry.path().filename() != "trace.csv") {
      ASSERT_LT(entry.file_size(), trace_size / 2) << entry.path();
    }
  }
  const uintmax_t limit_blocks = trace_size * 3 / 4 / 512;  // ulimit -f counts 512-byte blocks
  const std::string limit = "trap \"\" XFSZ; ulimit -f " + std::to_string(limit_blocks) + "; ";
  Result r = radlab(dir, "-q run " + toml + " --out " + dir.file("out"), limit);
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_OUTPUT_HAS(r, "trace.csv");
  EXPECT_FALSE(fs::exists(dir.file("out/trace.csv")));
  EXPECT_EQ(read_json_file(dir.file("out/sweep.json"))["status"], "running");
}

TEST(ReliabilityOutputs, OutputFileAppearsOnlyWhenCommitted) {
  TempDir dir;
  const std::string path = dir.file("a.txt");
  {
    OutputFile out(path);
    out.write("half");
    EXPECT_FALSE(fs::exists(path));  // under its temporary name until committed
  }
  EXPECT_TRUE(files_in(dir.path().string()).empty());  // abandoned: the temporary is gone
  OutputFile out(path);
  out.write("whole");
  out.commit();
  EXPECT_EQ(read_text(path), "whole");
}

// === 7. the JSON reader: a maintained parser, a depth limit, errors with the byte offset ======

TEST(ReliabilityJson, DeepNestingIsRefusedWithTheByteOffsetNotAStackOverflow) {
  // Defect: 10,000 nested brackets overflowed the old reader's stack (12 fuzz crashes).
  expect_error<InputError>([] { parse_json(std::string(100000, '['), "deep.json"); },
                           {"deep.json", "byte 64", "nested deeper than 64"});
  // Brackets inside strings do not count.
  EXPECT_EQ(parse_json("[\"" + std::string(1000, '[') + "\"]", "s.json")[0].get<std::string>(),
            std::string(1000, '['));
  // Through merge, as a shard's sweep.json.
  TempDir dir;
  run_two_shards(dir);
  write_text(dir.file("s1/sweep.json"), std::string(10000, '[') + std::string(10000, ']'));
  expect_error<InputError>(
      [&] {
        merge_sweeps({dir.file("s0"), dir.file("s1")}, dir.file("m"));
      },
      {"s1/sweep.json", "byte 64"});
}

TEST(ReliabilityJson, BadEscapesAndHugeNumbersAreInvalidInputWithTheByteOffset) {
  // Defect: an uncaught stoul/stoll on a bad escape or a huge number ended as exit 1.
  expect_error<InputError>([] { parse_json("{\"a\": \"\\uZZZZ\"}", "e.json"); },
                           {"e.json", "bad JSON at byte"});
  expect_error<InputError>([] { parse_json("{\"a\": 1e99999}", "n.json"); }, {"n.json"});
  expect_error<InputError>([] { parse_json("{\"a\": [1, 2}", "b.json"); },
                           {"b.json", "bad JSON at byte 11"});
  // Integers beyond 64 bits parse as floating point; merge refuses them where it needs an index.
  TempDir dir;
  run_two_shards(dir);
  replace_in_file(dir.file("s1/sweep.json"), "\"runs_total\": 2",
                  "\"runs_total\": 99999999999999999999999");
  expect_error<InputError>(
      [&] {
        merge_sweeps({dir.file("s0"), dir.file("s1")}, dir.file("m"));
      },
      {"runs_total"});
  // The command line: exit 3, naming the file.
  write_text(dir.file("s1/sweep.json"), "{\"status\": \"\\uZZZZ\"}");
  Result r =
      radlab(dir, "merge " + dir.file("s0") + " " + dir.file("s1") + " --out " + dir.file("m"));
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_OUTPUT_HAS(r, "s1/sweep.json: bad JSON at byte");
}

// === 10. unwritable outputs ====================================================================

TEST(ReliabilityUnwritable, RunAndMergeIntoAnUnwritableFolderAreInvalidInputNotInternalErrors) {
  // Defect: run/merge on a read-only folder ended as "internal error", exit 1. Here the folder
  // lies under a regular file (ENOTDIR), which fails for root too; a read-only folder follows
  // when the tests do not run as root (root ignores permissions).
  TempDir dir;
  const std::string toml = dir.write("e.toml", kTwoRuns);
  write_text(dir.file("file"), "");
  std::vector<std::string> unwritable = {dir.file("file") + "/out"};
  if (geteuid() != 0) {
    fs::create_directories(dir.file("ro"));
    fs::permissions(dir.file("ro"), fs::perms::owner_read | fs::perms::owner_exec);
    unwritable.push_back(dir.file("ro") + "/out");
  }
  run_two_shards(dir);
  for (const std::string& out : unwritable) {
    Result run = radlab(dir, "-q run " + toml + " --out " + out);
    EXPECT_EQ(run.code, 3) << run.output;
    EXPECT_EQ(run.output.find("internal error"), std::string::npos) << run.output;
    Result merge = radlab(dir, "merge " + dir.file("s0") + " " + dir.file("s1") + " --out " + out);
    EXPECT_EQ(merge.code, 3) << merge.output;
    EXPECT_EQ(merge.output.find("internal error"), std::string::npos) << merge.output;
  }
  if (geteuid() != 0) fs::permissions(dir.file("ro"), fs::perms::owner_all);
}

TEST(ReliabilityUnwritable, SolveAndFormfactorsCheckTheirOutputsBeforeComputing) {
  // Defect: solve and formfactors found an unwritable output only after the whole computation.
  TempDir dir;
  write_text(dir.file("file"), "");
  const std::string bad = dir.file("file") + "/x.csv";
  Result ff = radlab(dir, "formfactors builtin:cornell --subdiv 2 --out " + bad);
  EXPECT_EQ(ff.code, 3) << ff.output;
  EXPECT_OUTPUT_HAS(ff, dir.file("file"));
  EXPECT_EQ(ff.output.find("elements"), std::string::npos) << "computed first:\n" << ff.output;
  for (const char* option : {"--trace", "--out", "--json", "--image"}) {
    Result solve = radlab(dir, "solve builtin:cube --subdiv 2 --solver gauss-seidel --steps 5 " +
                                   std::string(option) + " " + bad);
    EXPECT_EQ(solve.code, 3) << option << ": " << solve.output;
    EXPECT_EQ(solve.output.find("stopped"), std::string::npos) << option << " computed first:\n"
                                                               << solve.output;
  }
}

TEST(ReliabilityUnwritable, ARunIdTooLongForAFileNameFailsThatRunNotTheSweep) {
  // Defect: one over-long run-id file name stopped the whole sweep. rho=0.8000...0 (300 zeros)
  // is the same material as rho=0.8 but a run id of over 300 bytes.
  TempDir dir;
  std::string text = kTwoRuns;
  text.replace(
      text.find("scenes = [\"builtin:cube:rho=0.8\"]"), 33,
      "scenes = [\"builtin:cube:rho=0.8\", \"builtin:cube:rho=0.8" + std::string(300, '0') + "\"]");
  ExperimentSpec spec = read_experiment(dir.write("e.toml", text));
  ASSERT_EQ(plan_sweep(spec).runs.size(), 4u);
  SweepReport report;
  ASSERT_NO_THROW(report = run_sweep(spec, {dir.file("out"), 0, 1, "test"}));
  EXPECT_EQ(report.runs_done, 4u);
  ASSERT_EQ(report.failures.size(), 2u);
  for (const RunFailure& f : report.failures) {
    EXPECT_NE(f.message.find("too long for a file name"), std::string::npos) << f.message;
    EXPECT_EQ(f.code, ExitCode::kInvalidInput);
  }
  const CsvTable summary = read_csv(dir.file("out/summary.csv"));
  ASSERT_EQ(summary.rows.size(), 4u);
  EXPECT_EQ(read_json_file(dir.file("out/sweep.json"))["failed"].size(), 2u);
}

// === 11. cache housekeeping ====================================================================

TEST(ReliabilityCache, StaleTemporariesOfKilledWritersAreRemovedSafely) {
  // Defect: a kill during a matrix write left its temporary file forever.
  TempDir dir;
  const fs::path folder = dir.path() / "cache";
  fs::create_directories(folder);
  const auto now = fs::file_time_type::clock::now();
  auto make = [&](const std::string& name, std::chrono::seconds age) {
    write_text((folder / name).string(), "partial");
    fs::last_write_time(folder / name, now - age);
    return folder / name;
  };
  // pid 2147483647 exceeds every pid_max: no such process. pid 1 always exists.
  const auto dead_old = make("a.ffm.tmp.2147483647.1", std::chrono::seconds(600));
  const auto dead_new = make("b.ffm.tmp.2147483647.2", std::chrono::seconds(0));
  const auto live = make("c.ffm.tmp.1.3", std::chrono::seconds(600));
  const auto live_ancient = make("d.ffm.tmp.1.4", std::chrono::hours(48));
  const auto other = make("e.ffm.tmp.notes", std::chrono::hours(48));

  MatrixCache cache(folder);
  FormFactorMatrix matrix(2, Precision::kDouble);
  MatrixCacheKey key;
  key.text = "test";
  key.hash = {1, 2};
  ASSERT_TRUE(cache.store(key, matrix, BuildReport{}));
  EXPECT_FALSE(fs::exists(dead_old));  // owner gone, over a minute old
  EXPECT_TRUE(fs::exists(dead_new));   // owner gone, but it may be another machine's, just begun
  EXPECT_TRUE(fs::exists(live));       // owner alive: possibly still writing
  EXPECT_FALSE(fs::exists(live_ancient));  // a day old: no write takes that long
  EXPECT_TRUE(fs::exists(other));          // not a name radlab gives
  EXPECT_TRUE(cache.load(key, nullptr).has_value());
}

TEST(ReliabilityCache, ConcurrentProcessesOnAnEmptyCacheBuildAMatrixOnce) {
  // Defect: concurrent shards on an empty cache each built the same matrix. Two processes start
  // together; the one that does not build waits for the other and loads its matrix.
  TempDir dir;
  const std::string ff = std::string(RADLAB_BINARY) + " formfactors builtin:cornell --subdiv 4";
  Result r =
      shell("export RADLAB_CACHE_DIR=" + dir.file("cache") + "; " + ff + " > " + dir.file("a.txt") +
            " 2>&1 & " + ff + " > " + dir.file("b.txt") + " 2>&1 & wait");
  ASSERT_EQ(r.code, 0) << r.output;
  const std::string a = read_text(dir.file("a.txt")), b = read_text(dir.file("b.txt"));
  const std::string loaded = "loaded now from the cache";
  const int built =
      int(a.find(loaded) == std::string::npos) + int(b.find(loaded) == std::string::npos);
  EXPECT_EQ(built, 1) << a << "\n----\n" << b;
}

}  // namespace
}  // namespace radlab
