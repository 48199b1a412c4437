#include "fuzz/targets.h"

#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <string>

#include "core/error.h"
#include "core/json_reader.h"
#include "experiments/sweep/experiment_spec.h"
#include "experiments/sweep/merge.h"
#include "experiments/sweep/sweep_folder.h"
#include "fuzz/fuzz_support.h"
#include "scene/mesh.h"
#include "scene/scene_loader.h"

namespace radlab::fuzz {
namespace {

// Reads a scene the way the command line does and meshes it at the default subdivision. The
// loader's area account (scene/validate.h) must balance: every square metre read is kept or
// named as dropped, cut or removed. An imbalance is a finding (issue 36.1: faces that vanished
// without a word), so it escapes as a non-radlab exception, not as a refusal.
void load_and_mesh(const std::filesystem::path& path) {
  LoadedScene loaded;
  try {
    loaded = load_scene(path.string(), false);
  } catch (const Error&) {
    return;  // a refusal with a message: the expected outcome for most mutated inputs
  }
  const AreaAccount& area = loaded.report.area;
  if (!area.balanced())
    throw std::logic_error("area account does not balance: " + std::to_string(area.unaccounted()) +
                           " of " + std::to_string(area.read) + " m^2 read is unaccounted for");
  try {
    build_mesh(loaded.scene, MeshOptions{});
  } catch (const Error&) {
  }
}

}  // namespace

void run_obj(const uint8_t* data, size_t size) {
  const auto parts = split_parts(data, size, 2);
  clear_scratch();
  write_file(scratch() / "scene.obj", parts[0]);
  write_file(scratch() / "m.mtl", parts[1]);
  load_and_mesh(scratch() / "scene.obj");
}

void run_mgf(const uint8_t* data, size_t size) {
  const auto parts = split_parts(data, size, 2);
  clear_scratch();
  write_file(scratch() / "main.mgf", parts[0]);
  write_file(scratch() / "inc.mgf", parts[1]);
  load_and_mesh(scratch() / "main.mgf");
}

void run_toml(const uint8_t* data, size_t size) {
  const auto parts = split_parts(data, size, 1);
  clear_scratch();
  const auto file = scratch() / "experiment.toml";
  write_file(file, parts[0]);
  try {
    plan_sweep(read_experiment(file.string()));
  } catch (const Error&) {
  }
}

void run_merge(const uint8_t* data, size_t size) {
  // Only the public merge_sweeps() is used: the harness does not depend on how merge parses
  // JSON or CSV.
  const auto parts = split_parts(data, size, 3);
  clear_scratch();
  const auto shard = scratch() / "shard";
  std::filesystem::create_directories(shard / "runs");
  write_file(shard / "sweep.json", parts[0]);
  write_file(shard / "summary.csv", parts[1]);
  write_file(shard / "trace.csv", parts[2]);
  // The shard's manifest (the SHA-256 of its files) is sealed here when sweep.json is an object
  // without one, so that mutated tables reach merge's parsers instead of its manifest check.
  try {
    Json sweep = read_json_file((shard / "sweep.json").string());
    if (sweep.is_object() && !sweep.contains("files")) {
      Json files = Json::array();
      for (const ManifestEntry& e : folder_manifest(shard))
        files.push_back({{"path", e.path}, {"sha256", e.sha256}, {"bytes", e.bytes}});
      sweep["files"] = files;
      write_file(shard / "sweep.json", sweep.dump());
    }
  } catch (const Error&) {
  }
  try {
    merge_sweeps({shard.string()}, (scratch() / "merged").string(), "fuzz");
  } catch (const Error&) {
  }
}

}  // namespace radlab::fuzz
