// Nothing mixed, nothing damaged (issue 36, items 2 and 5): a sweep's identity covers every file
// its scenes read, so an edited box.mtl between a kill and the resume, or between two shards, is
// never `complete` with two scene versions; each finished folder lists its files with their
// SHA-256, and `radlab merge` refuses a shard whose files do not match, naming the file; merge
// takes run's lock and refuses what run refuses. docs/reliability.md lists the cases.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "core/csv_reader.h"
#include "core/error.h"
#include "core/json_reader.h"
#include "core/sha256.h"
#include "experiments/run/summary.h"
#include "experiments/sweep/experiment_spec.h"
#include "experiments/sweep/merge.h"
#include "experiments/sweep/sweep.h"
#include "experiments/sweep/sweep_folder.h"
#include "tests/experiment_fixtures.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

namespace fs = std::filesystem;
using testing::expect_error;
using testing::TempDir;
using Result = testing::CommandResult;

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// `radlab ARGUMENTS` with the folder's own cache.
Result radlab(const TempDir& dir, const std::string& arguments) {
  return testing::run_command("RADLAB_CACHE_DIR=" + dir.file("cache") + " timeout 300 " +
                              std::string(RADLAB_BINARY) + " " + arguments);
}

#define EXPECT_OUTPUT_HAS(result, text) \
  EXPECT_NE((result).output.find(text), std::string::npos) << (result).output

// Two gauss-seidel runs on the OBJ box (24 elements), a few milliseconds each.
std::string box_experiment(const TempDir& dir) {
  dir.write("box.obj", testing::kBoxObj);
  dir.write("box.mtl", testing::kBoxMtl);
  return dir.write("e.toml", R"(name = "box"
scenes = ["box.obj"]
subdiv = 2
solvers = ["gauss-seidel"]
[form_factors]
rays = 4
[budget]
rows = 200
[parameters.gauss-seidel]
omega = [1.0, 1.3]
)");
}

// The walls' reflectance 0.5 -> 0.8: what issue 36.2 edited between a kill and the resume.
void edit_kd(const TempDir& dir) {
  std::string mtl = testing::kBoxMtl;
  mtl.replace(mtl.find("Kd 0.5 0.5 0.5"), 14, "Kd 0.8 0.8 0.8");
  write_text(dir.file("box.mtl"), mtl);
}

// The summary's rows without the columns that measure time.
std::vector<std::vector<std::string>> timeless_summary(const std::string& path) {
  return testing::without_columns(read_csv(path), summary_time_columns());
}

// === Item 2: the scene files are part of the sweep's identity =================================

TEST(ReliabilityScenes, SweepJsonAndRunJsonListTheSceneFilesWithTheirSha256) {
  TempDir dir;
  const ExperimentSpec spec = read_experiment(box_experiment(dir));
  run_sweep(spec, {dir.file("out"), 0, 1, "test"});
  const Json sweep = read_json_file(dir.file("out/sweep.json"));
  ASSERT_EQ(sweep["scene_files"].size(), 2u) << sweep.dump(2);
  EXPECT_EQ(sweep["scene_files"][1]["sha256"], file_sha256(dir.file("box.mtl")));
  const Json run = read_json_file(dir.file("out/runs/gauss-seidel_scene_box_omega_1.run.json"));
  EXPECT_EQ(run["scene"]["files"], sweep["scene_files"]);
}

TEST(ReliabilityScenes, AnEditedMaterialBetweenAKillAndTheResumeRedoesTheSweep) {
  // Defect: box.mtl's Kd edited between a kill and the resume; the sweep finished `complete`,
  // exit 0, with the run done before the kill computed on the old scene.
  TempDir dir;
  write_text(dir.file("box.obj"), testing::kBoxObj);
  write_text(dir.file("box.mtl"), testing::kBoxMtl);
  // Three runs of ~0.4 s (jacobi on the 216-element box, 300k rows), so the kill lands mid-sweep.
  const std::string toml = dir.write("slow.toml", R"(name = "slow-box"
scenes = ["box.obj"]
subdiv = 6
solvers = ["jacobi"]
[form_factors]
rays = 4
[budget]
rows = 300000
[parameters.jacobi]
omega = [1.0, 0.9, 0.8]
)");
  const std::string out = dir.file("out");
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    setenv("RADLAB_CACHE_DIR", dir.file("cache").c_str(), 1);
    freopen("/dev/null", "w", stdout);
    freopen("/dev/null", "w", stderr);
    execl(RADLAB_BINARY, RADLAB_BINARY, "run", toml.c_str(), "--out", out.c_str(), nullptr);
    _exit(127);
  }
  // Killed once its first run is complete (its summary row waits in the partial folder).
  const std::string first_done = out + "/.radlab-partial/000000.summary.csv";
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (!fs::exists(first_done) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  kill(child, SIGKILL);
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the sweep finished before it could be killed";
  ASSERT_EQ(read_json_file(out + "/sweep.json")["status"], "running");

  edit_kd(dir);
  const Result resumed = radlab(dir, "run " + toml + " --out " + out);
  ASSERT_EQ(resumed.code, 0) << resumed.output;
  // Not resumed: replaced, saying which file changed, and every run done on the new scene.
  EXPECT_OUTPUT_HAS(resumed, "box.mtl changed");
  EXPECT_EQ(resumed.output.find("already complete"), std::string::npos) << resumed.output;
  const Result fresh = radlab(dir, "-q run " + toml + " --out " + dir.file("fresh"));
  ASSERT_EQ(fresh.code, 0) << fresh.output;
  EXPECT_EQ(timeless_summary(out + "/summary.csv"),
            timeless_summary(dir.file("fresh/summary.csv")));
}

TEST(ReliabilityScenes, AResumeChecksEachRunsSceneFilesToo) {
  // A run.json recorded on other scene files is not "already complete", even when sweep.json
  // says nothing changed (a folder put together by hand, or a file restored to its old bytes).
  TempDir dir;
  const ExperimentSpec spec = read_experiment(box_experiment(dir));
  const SweepPlan plan = plan_sweep(spec);
  const PlannedRun& run = plan.runs[0];
  const SweepIdentity identity = sweep_identity(spec, plan, "0/1");
  const std::vector<SourceFile>& files =
      identity.scene_files.at(plan.problems[run.problem].spec.scene);
  ASSERT_EQ(files.size(), 2u);
  const std::string stem = file_stem(run.run_id);
  fs::create_directories(dir.file("out/runs"));
  fs::create_directories(partial_folder(dir.file("out")));
  write_text(partial_file(dir.file("out"), 0, "trace").string(), "h\n");
  write_text(partial_file(dir.file("out"), 0, "summary").string(), "h\n");
  auto run_json = [&](const std::string& sha) {
    Json json = {{"run_id", run.run_id},
                 {"run_index", 0u},
                 {"scene", {{"files", Json::array()}}},
                 {"run", {{"stop_reason", "row budget"}}}};
    for (const SourceFile& f : files)
      json["scene"]["files"].push_back(
          {{"path", f.path}, {"sha256", sha.empty() ? f.sha256 : sha}});
    write_text(dir.file("out/runs/" + stem + ".run.json"), json.dump());
  };
  run_json("");
  EXPECT_TRUE(completed_run(dir.file("out"), run, stem, files).has_value());
  run_json(std::string(64, '0'));
  EXPECT_FALSE(completed_run(dir.file("out"), run, stem, files).has_value());
}

TEST(ReliabilityMerge, RefusesShardsOfDifferentSceneVersionsNamingTheFile) {
  // Defect: shard 0 on Kd 0.5, shard 1 on Kd 0.8 merged with exit 0.
  TempDir dir;
  const ExperimentSpec spec = read_experiment(box_experiment(dir));
  run_sweep(spec, {dir.file("s0"), 0, 2, "test"});
  edit_kd(dir);
  run_sweep(spec, {dir.file("s1"), 1, 2, "test"});
  expect_error<InputError>(
      [&] {
        merge_sweeps({dir.file("s0"), dir.file("s1")}, dir.file("m"));
      },
      {"box.mtl changed", "different versions of the scene"});
  EXPECT_FALSE(fs::exists(dir.file("m")));
}

// === Item 5: each shard's files are covered by a manifest merge checks ========================

class ReliabilityManifest : public ::testing::Test {
 protected:
  void SetUp() override {
    const ExperimentSpec spec = read_experiment(dir_.write("e.toml", testing::kTwoRuns));
    run_sweep(spec, {dir_.file("s0"), 0, 2, "test"});
    run_sweep(spec, {dir_.file("s1"), 1, 2, "test"});
  }
  void expect_refused(std::initializer_list<std::string> parts) {
    expect_error<InputError>(
        [&] {
          merge_sweeps({dir_.file("s0"), dir_.file("s1")}, dir_.file("m"));
        },
        parts);
    EXPECT_FALSE(fs::exists(dir_.file("m")));
  }
  TempDir dir_;
};

TEST_F(ReliabilityManifest, SweepJsonListsEveryFileWithItsSha256) {
  const Json sweep = read_json_file(dir_.file("s0/sweep.json"));
  std::vector<std::string> paths;
  for (const Json& e : sweep["files"]) {
    paths.push_back(e["path"].get<std::string>());
    EXPECT_EQ(e["sha256"], file_sha256(dir_.file("s0/" + paths.back()))) << paths.back();
  }
  EXPECT_EQ(paths,
            (std::vector<std::string>{"trace.csv", "summary.csv",
                                      "runs/gauss-seidel_scene_cube_rho_0.8_omega_1.radiosity.csv",
                                      "runs/gauss-seidel_scene_cube_rho_0.8_omega_1.run.json"}));
  // The merged folder has its own.
  ASSERT_EQ(merge_sweeps({dir_.file("s0"), dir_.file("s1")}, dir_.file("m")), 2u);
  const Json merged = read_json_file(dir_.file("m/sweep.json"));
  EXPECT_EQ(merged["files"].size(), 6u);
  EXPECT_NO_THROW(verify_manifest(dir_.file("m"), merged));
}

TEST_F(ReliabilityManifest, AShardWithAnEmptyRunsFolderIsRefused) {
  // Defect: a shard whose runs/ was emptied merged with exit 0.
  for (const auto& entry : fs::directory_iterator(dir_.file("s1/runs"))) fs::remove(entry.path());
  expect_refused({"s1/runs/", "missing"});
}

TEST_F(ReliabilityManifest, DeletedTraceRowsAreRefused) {
  std::string trace = read_text(dir_.file("s0/trace.csv"));
  trace.erase(trace.rfind('\n', trace.size() - 2) + 1);  // the last row
  write_text(dir_.file("s0/trace.csv"), trace);
  expect_refused({"s0/trace.csv", "differs from", "manifest"});
}

TEST_F(ReliabilityManifest, AnEditedSummaryValueIsRefused) {
  // Same size, another value: a digit of the last field changed.
  std::string summary = read_text(dir_.file("s1/summary.csv"));
  const size_t digit = summary.find_last_of("0123456789");
  summary[digit] = summary[digit] == '1' ? '2' : '1';
  write_text(dir_.file("s1/summary.csv"), summary);
  expect_refused({"s1/summary.csv", "another SHA-256"});
}

TEST_F(ReliabilityManifest, AFileAddedToAShardIsRefused) {
  write_text(dir_.file("s0/runs/stray.run.json"), "{}");
  expect_refused({"s0/runs/stray.run.json", "not in"});
}

TEST_F(ReliabilityManifest, MergeOntoAnotherExperimentsSweepNeedsOverwrite) {
  // Defect: `merge --out` onto another experiment's complete sweep deleted it; run refuses that.
  std::string other = testing::kTwoRuns;
  other.replace(other.find("tiny"), 4, "other");
  run_sweep(read_experiment(dir_.write("o.toml", other)), {dir_.file("m"), 0, 1, "test"});
  const std::string before = read_text(dir_.file("m/summary.csv"));
  expect_error<UsageError>(
      [&] {
        merge_sweeps({dir_.file("s0"), dir_.file("s1")}, dir_.file("m"));
      },
      {"holds a sweep of experiment 'other'", "--overwrite"});
  EXPECT_EQ(read_text(dir_.file("m/summary.csv")), before);
  // A shard of this experiment (not one merged here) is not a merge's to replace either.
  MergeOptions partial;
  partial.allow_incomplete = true;
  expect_error<UsageError>([&] { merge_shards({dir_.file("s0")}, dir_.file("s1"), partial); },
                           {"holds shard 1/2 of experiment 'tiny', not a merged sweep"});
  EXPECT_EQ(read_json_file(dir_.file("s1/sweep.json"))["shard"], "1/2");
  MergeOptions overwrite;
  overwrite.overwrite = true;
  EXPECT_EQ(merge_shards({dir_.file("s0"), dir_.file("s1")}, dir_.file("m"), overwrite), 2u);
  EXPECT_EQ(read_json_file(dir_.file("m/sweep.json"))["name"], "tiny");
  // The command line: exit 2 without --overwrite.
  run_sweep(read_experiment(dir_.file("o.toml")), {dir_.file("m2"), 0, 1, "test"});
  const Result r = radlab(
      dir_, "merge " + dir_.file("s0") + " " + dir_.file("s1") + " --out " + dir_.file("m2"));
  EXPECT_EQ(r.code, 2) << r.output;
  const Result forced = radlab(dir_, "merge " + dir_.file("s0") + " " + dir_.file("s1") +
                                         " --out " + dir_.file("m2") + " --overwrite");
  EXPECT_EQ(forced.code, 0) << forced.output;
}

TEST_F(ReliabilityManifest, MergeRefusesAFolderARunIsWriting) {
  // Defect: merge ignored the lock of a `run` writing --out; the run then died with exit 3 and
  // left a file in the merged folder. The lock is the one a run takes (flock, per open file).
  fs::create_directories(dir_.file("m"));
  {
    SweepFolderLock running(dir_.file("m"));
    expect_error<UsageError>(
        [&] {
          merge_sweeps({dir_.file("s0"), dir_.file("s1")}, dir_.file("m"));
        },
        {"another radlab process is writing"});
  }
  // Released, the merge goes ahead; the merged folder carries the lock file a run would take.
  EXPECT_EQ(merge_sweeps({dir_.file("s0"), dir_.file("s1")}, dir_.file("m")), 2u);
  EXPECT_TRUE(fs::exists(dir_.file("m/.radlab.lock")));
}

}  // namespace
}  // namespace radlab
