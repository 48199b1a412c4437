#include "experiments/sweep/experiment_spec.h"

#include <toml++/toml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <limits>
#include <set>

#include "core/error.h"
#include "core/limits.h"
#include "core/text.h"
#include "solvers/registry.h"

namespace radlab {
namespace {

bool valid_name(const std::string& name) {
  if (name.empty() || name == "." || name == ".." || name.size() > 200) return false;
  for (char c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '_'))
      return false;
  return true;
}

class Reader {
 public:
  explicit Reader(std::string path) : path_(std::move(path)) {}

  [[noreturn]] void fail(const toml::node& node, const std::string& message) const {
    throw InputError(path_ + ":" + std::to_string(node.source().begin.line) + ": " + message);
  }
  [[noreturn]] void fail_at(const toml::source_region& where, const std::string& message) const {
    throw InputError(path_ + ":" + std::to_string(where.begin.line) + ": " + message);
  }

  // Rejects keys not in `allowed`, naming the line and listing the valid keys.
  void only(const toml::table& table, const std::set<std::string>& allowed,
            const std::string& where) const {
    for (auto&& [key, node] : table) {
      if (allowed.count(std::string(key.str()))) continue;
      fail_at(key.source(),
              "unknown key '" + std::string(key.str()) + "' in " + where + "; valid keys: " +
                  text::join(std::vector<std::string>(allowed.begin(), allowed.end()), ", "));
    }
  }

  std::string string(const toml::node& node, const std::string& what) const {
    if (node.is_string()) return *node.value<std::string>();
    fail(node, what + " must be a string");
  }
  long long integer(const toml::node& node, const std::string& what) const {
    if (node.is_integer()) return *node.value<int64_t>();
    fail(node, what + " must be an integer");
  }
  double number(const toml::node& node, const std::string& what) const {
    if (node.is_integer()) return double(*node.value<int64_t>());
    if (node.is_floating_point()) return *node.value<double>();
    fail(node, what + " must be a number");
  }
  // Any scalar as text (for solver and method parameters): booleans as true/false.
  std::string scalar(const toml::node& node, const std::string& what) const {
    // Check the node's own type: toml++'s value<T>() converts between types.
    if (node.is_boolean()) return *node.value<bool>() ? "true" : "false";
    if (node.is_integer()) return std::to_string(*node.value<int64_t>());
    if (node.is_floating_point()) return text::format_double(*node.value<double>());
    if (node.is_string()) return *node.value<std::string>();
    fail(node, what + " must be a string, number or boolean");
  }
  // A scalar or an array of scalars, as a list.
  template <class Fn>
  auto list(const toml::node& node, Fn&& item) const {
    using T = decltype(item(node));
    std::vector<T> out;
    if (const toml::array* array = node.as_array()) {
      for (const toml::node& element : *array) out.push_back(item(element));
      if (out.empty()) fail(node, "an empty list is not allowed here");
    } else {
      out.push_back(item(node));
    }
    return out;
  }
  // A list whose entries must differ (equal entries would plan runs with the same run id, which
  // overwrite each other): the second of two equal entries is refused, naming its line.
  template <class Fn>
  auto distinct_list(const toml::node& node, const std::string& what, Fn&& item) const {
    using T = decltype(item(node));
    std::vector<T> out;
    std::set<T> seen;
    auto add = [&](const toml::node& element) {
      T value = item(element);
      if (!seen.insert(value).second)
        fail(element, what + " lists the same entry twice (runs would share a run id)");
      out.push_back(std::move(value));
    };
    if (const toml::array* array = node.as_array()) {
      for (const toml::node& element : *array) add(element);
      if (out.empty()) fail(node, "an empty list is not allowed here");
    } else {
      add(node);
    }
    return out;
  }

 private:
  std::string path_;
};

toml::table parse_toml(const std::string& path) {
  if (!std::filesystem::exists(path)) throw InputError(path + ": no such file");
  try {
    return toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    throw InputError(path + ":" + std::to_string(e.source().begin.line) + ": " +
                     std::string(e.description()));
  }
}

void read_name(const Reader& r, const toml::table& root, ExperimentSpec& spec) {
  spec.name = std::filesystem::path(spec.path).stem().string();
  if (auto n = root["name"]) {
    spec.name = r.string(*n.node(), "name");
    // The name becomes the default output folder out/NAME: no way out of out/.
    if (!valid_name(spec.name))
      r.fail(*n.node(), "name '" + spec.name +
                            "' must be a plain file name: letters, digits, "
                            "'.', '-', '_', not '.' or '..', no path separators");
  }
  if (auto n = root["description"]) spec.description = r.string(*n.node(), "description");
}

void read_scenes(const Reader& r, const toml::table& root, ExperimentSpec& spec) {
  auto scenes = root["scenes"];
  if (!scenes) throw InputError(spec.path + ": 'scenes' is required (a list of scene specs)");
  spec.scenes = r.distinct_list(*scenes.node(), "scenes",
                                [&](const toml::node& n) { return r.string(n, "scene"); });
}

// subdiv or element_size: the mesh axis.
void read_meshes(const Reader& r, const toml::table& root, ExperimentSpec& spec) {
  if (root["subdiv"] && root["element_size"])
    r.fail(*root["element_size"].node(), "give 'subdiv' or 'element_size', not both");
  if (auto n = root["element_size"]) {
    for (double h : r.distinct_list(*n.node(), "element_size", [&](const toml::node& v) {
           double h = r.number(v, "element_size");
           if (!(h > 0) || !std::isfinite(h)) r.fail(v, "element_size must be a finite number > 0");
           return h;
         }))
      spec.meshes.push_back(MeshOptions{1, h});
  } else if (auto s = root["subdiv"]) {
    for (long long k : r.distinct_list(*s.node(), "subdiv", [&](const toml::node& v) {
           long long k = r.integer(v, "subdiv");
           // Checked in 64 bits before it becomes an int (4294967298 is not 2).
           if (k < 1 || k > std::numeric_limits<int>::max())
             r.fail(v, "subdiv must lie in [1, 2147483647], got " + std::to_string(k));
           return k;
         }))
      spec.meshes.push_back(MeshOptions{int(k), 0.0});
  } else {
    spec.meshes.push_back(MeshOptions{});
  }
}

// Returns true when the list said "all": narrowed to what runs on the problem by
// narrow_all_solvers, once [patches] is read.
bool read_solvers(const Reader& r, const toml::table& root, ExperimentSpec& spec) {
  auto solvers = root["solvers"];
  bool all_solvers = false;
  if (!solvers) throw InputError(spec.path + ": 'solvers' is required (names, or [\"all\"])");
  for (const std::string& name :
       r.list(*solvers.node(), [&](const toml::node& n) { return r.string(n, "solver"); })) {
    if (name == "all") {
      for (const SolverInfo& info : solver_registry()) spec.solvers.push_back({info.name, {}});
      all_solvers = true;
      continue;
    }
    try {
      solver_info(name);
    } catch (const UsageError& e) {
      r.fail(*solvers.node(), e.what());
    }
    spec.solvers.push_back({name, {}});
  }
  for (size_t i = 0; i < spec.solvers.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if (spec.solvers[i].name == spec.solvers[j].name)
        r.fail(*solvers.node(), "solvers lists '" + spec.solvers[i].name +
                                    "' twice (runs would share a run id; 'all' includes it)");
  return all_solvers;
}

void read_seeds(const Reader& r, const toml::table& root, ExperimentSpec& spec) {
  if (auto n = root["seeds"])
    spec.seeds = r.distinct_list(*n.node(), "seeds", [&](const toml::node& v) {
      const long long seed = r.integer(v, "seed");
      if (seed < 0) r.fail(v, "seeds must be >= 0, got " + std::to_string(seed));
      return seed;
    });
}

// solver_seeds = [...] or repeats = K (seeds 0..K-1): named apart from `seeds`, which are the
// form factors' seeds (a new problem each), since these repeat runs on the same problem.
void read_solver_seeds(const Reader& r, const toml::table& root, ExperimentSpec& spec) {
  if (root["solver_seeds"] && root["repeats"])
    r.fail(*root["repeats"].node(), "give 'solver_seeds' or 'repeats', not both");
  if (auto n = root["solver_seeds"])
    spec.solver_seeds = r.distinct_list(*n.node(), "solver_seeds", [&](const toml::node& v) {
      const long long seed = r.integer(v, "solver seed");
      if (seed < 0) r.fail(v, "solver_seeds must be >= 0, got " + std::to_string(seed));
      return seed;
    });
  if (auto n = root["repeats"]) {
    const long long k = r.integer(*n.node(), "repeats");
    // Checked here against the runs limit's order of magnitude before any list is built.
    if (k < 1 || k > 1000000)
      r.fail(*n.node(), "repeats must lie in [1, 1000000], got " + std::to_string(k));
    for (long long seed = 0; seed < k; ++seed) spec.solver_seeds.push_back(seed);
  }
}

// The solver seeds become each solver's `seed` axis. A solver without a `seed` parameter would
// give K identical runs, and a `seed` axis of its own would clash: both are refused.
void apply_solver_seeds(const Reader& r, const toml::table& root, ExperimentSpec& spec) {
  if (spec.solver_seeds.empty()) return;
  const char* key = root["solver_seeds"] ? "solver_seeds" : "repeats";
  const toml::node& node = *root[key].node();
  std::vector<std::string> seeds;
  for (long long seed : spec.solver_seeds) seeds.push_back(std::to_string(seed));
  for (SolverSweep& solver : spec.solvers) {
    const SolverInfo& info = solver_info(solver.name);
    const bool seeded = std::any_of(info.parameters.begin(), info.parameters.end(),
                                    [](const ParameterInfo& p) { return p.name == "seed"; });
    if (!seeded)
      r.fail(node, std::string(key) + ": solver '" + solver.name +
                       "' has no 'seed' parameter (its runs over seeds would be identical); "
                       "list only seeded solvers in an experiment with '" +
                       key + "'");
    if (solver.parameters.count("seed"))
      r.fail(node, std::string(key) + ": [parameters." + solver.name +
                       "] gives 'seed' too; give the seeds in one place");
    solver.parameters["seed"] = seeds;
  }
}

void read_form_factors(const Reader& r, const toml::table& root, ExperimentSpec& spec) {
  if (const toml::table* ff = root["form_factors"].as_table()) {
    for (auto&& [key, node] : *ff) {
      const std::string k(key.str());
      if (k == "method") {
        spec.ff_method = r.string(node, "form_factors.method");
      } else if (k == "mode") {
        const std::string mode = r.string(node, "form_factors.mode");
        if (mode != "cached" && mode != "on-the-fly")
          r.fail(node, "form_factors.mode must be 'cached' or 'on-the-fly'");
        spec.row_mode = mode == "cached" ? RowMode::kCached : RowMode::kOnTheFly;
      } else if (k == "precision") {
        const std::string p = r.string(node, "form_factors.precision");
        if (p != "float" && p != "double")
          r.fail(node, "form_factors.precision must be 'float' or 'double'");
        spec.precision = p == "float" ? Precision::kFloat : Precision::kDouble;
      } else if (k == "seed") {
        r.fail_at(key.source(), "give form-factor seeds with the top-level 'seeds' list");
      } else {
        spec.ff_parameters[k] = r.scalar(node, "form_factors." + k);  // checked by the method
      }
    }
  } else if (root["form_factors"]) {
    r.fail(*root["form_factors"].node(), "'form_factors' must be a table");
  }
}

void read_patches(const Reader& r, const toml::table& root, ExperimentSpec& spec) {
  if (const toml::table* pt = root["patches"].as_table()) {
    r.only(*pt, {"from", "size", "rows"}, "[patches]");
    if (auto n = (*pt)["from"]) spec.patches.from = r.string(*n.node(), "patches.from");
    if (auto n = (*pt)["size"]) spec.patches.size = r.number(*n.node(), "patches.size");
    if (auto n = (*pt)["rows"]) spec.patches.rows = r.string(*n.node(), "patches.rows");
    try {
      spec.patches.validate();
    } catch (const UsageError& e) {
      r.fail(*root["patches"].node(), e.what());
    }
  } else if (root["patches"]) {
    r.fail(*root["patches"].node(), "'patches' must be a table");
  }
}

// "all" means every solver that runs on this problem's system (docs/experiments.md):
// adaptive-shooting needs patches (on one level it is sorted-shooting again); on two levels
// conjugate-gradient needs a reciprocal system (K is not: A_e K_ej != A_j K_je) and
// hierarchical solves its own one-level system. The Monte Carlo solvers are left out
// (needs_step_or_time_budget: "all" runs share a budget, usually in rows, which they never spend);
// list them by name with a steps or seconds budget.
void narrow_all_solvers(ExperimentSpec& spec) {
  const bool two = spec.patches.two_level();
  std::erase_if(spec.solvers, [two](const SolverSweep& s) {
    if (needs_step_or_time_budget(s.name)) return true;
    return two ? s.name == "conjugate-gradient" || s.name == "hierarchical"
               : s.name == "adaptive-shooting";
  });
}

void read_budget(const Reader& r, const toml::table& root, ExperimentSpec& spec) {
  if (const toml::table* b = root["budget"].as_table()) {
    r.only(*b, {"steps", "rows", "seconds", "tol", "tol_of"}, "[budget]");
    // A budget that cannot mean anything is an error, never a silent default (or a hang: a NaN
    // time limit is never reached); the rules are budget_violation's, the line the key's.
    if (auto n = (*b)["steps"]) spec.budget.steps = r.integer(*n.node(), "budget.steps");
    if (auto n = (*b)["rows"]) spec.budget.rows = r.integer(*n.node(), "budget.rows");
    if (auto n = (*b)["seconds"]) spec.budget.seconds = r.number(*n.node(), "budget.seconds");
    if (auto n = (*b)["tol"]) spec.budget.tol = r.number(*n.node(), "budget.tol");
    if (auto violation = budget_violation(spec.budget))
      r.fail(*(*b)[violation->field].node(),
             "budget." + violation->field + " " + violation->requirement);
    // What the tolerance is relative to, as `radlab solve --tol-of`: max B* (the default) or the
    // reflected light max(B* - E), which a tiny bright emitter would otherwise dominate.
    if (auto n = (*b)["tol_of"]) {
      const std::string of = r.string(*n.node(), "budget.tol_of");
      if (of != "max-b" && of != "reflected")
        r.fail(*n.node(), "budget.tol_of must be \"max-b\" or \"reflected\", got \"" + of + "\"");
      if (!spec.budget.tol) r.fail(*n.node(), "budget.tol_of needs budget.tol");
      spec.budget.tol_of_reflected = of == "reflected";
    }
  }
}

void read_checkpoints(const Reader& r, const toml::table& root, ExperimentSpec& spec) {
  if (const toml::table* c = root["checkpoints"].as_table()) {
    r.only(*c, {"every_step_until", "growth", "extra"}, "[checkpoints]");
    if (auto n = (*c)["every_step_until"])
      spec.schedule.every_step_until = r.integer(*n.node(), "checkpoints.every_step_until");
    if (auto n = (*c)["growth"]) {
      spec.schedule.growth = r.number(*n.node(), "checkpoints.growth");
      if (!(spec.schedule.growth > 1.0)) r.fail(*n.node(), "checkpoints.growth must be > 1");
    }
    if (auto n = (*c)["extra"])
      spec.schedule.extra =
          r.list(*n.node(), [&](const toml::node& v) { return r.integer(v, "checkpoint"); });
  }
}

// [parameters.SOLVER]: each key a parameter axis of a solver the experiment lists.
void read_parameters(const Reader& r, const toml::table& root, ExperimentSpec& spec) {
  if (const toml::table* p = root["parameters"].as_table()) {
    for (auto&& [key, node] : *p) {
      const std::string solver(key.str());
      auto it = std::find_if(spec.solvers.begin(), spec.solvers.end(),
                             [&](const SolverSweep& s) { return s.name == solver; });
      if (it == spec.solvers.end())
        r.fail_at(key.source(), "[parameters." + solver + "]: '" + solver +
                                    "' is not among the experiment's solvers");
      const toml::table* table = node.as_table();
      if (!table) r.fail(node, "[parameters." + solver + "] must be a table");
      const SolverInfo& info = solver_info(solver);
      std::set<std::string> valid;
      for (const ParameterInfo& pi : info.parameters) valid.insert(pi.name);
      r.only(*table, valid, "[parameters." + solver + "]");
      for (auto&& [pkey, pnode] : *table) {
        const std::string what = "parameters." + solver + "." + std::string(pkey.str());
        it->parameters[std::string(pkey.str())] =
            r.distinct_list(pnode, what, [&](const toml::node& v) { return r.scalar(v, what); });
      }
    }
  }
}

void read_images(const Reader& r, const toml::table& root, ExperimentSpec& spec) {
  if (const toml::table* im = root["images"].as_table()) {
    r.only(*im, {"steps", "width", "height", "error_maps", "shading"}, "[images]");
    if (auto n = (*im)["shading"]) {
      const std::string shading = r.string(*n.node(), "images.shading");
      if (shading != "gouraud" && shading != "flat")
        r.fail(*n.node(), "images.shading must be 'gouraud' or 'flat'");
      spec.images.smooth = shading == "gouraud";
    }
    if (auto n = (*im)["steps"])
      spec.images.steps =
          r.list(*n.node(), [&](const toml::node& v) { return r.integer(v, "images.steps"); });
    // Range-checked in 64 bits before narrowing (4294967304 is not 8).
    for (const char* key : {"width", "height"})
      if (auto n = (*im)[key]) {
        const long long v = r.integer(*n.node(), std::string("images.") + key);
        if (v < 8 || v > 8192)
          r.fail(*n.node(),
                 std::string("images.") + key + " must lie in [8, 8192], got " + std::to_string(v));
        (std::string(key) == "width" ? spec.images.width : spec.images.height) = int(v);
      }
    if (auto n = (*im)["error_maps"]) {
      if (!n.is_boolean()) r.fail(*n.node(), "images.error_maps must be true or false");
      spec.images.error_maps = *n.value<bool>();
    }
    if (spec.images.width < 8 || spec.images.height < 8 || spec.images.width > 8192 ||
        spec.images.height > 8192)
      throw InputError(spec.path + ": [images] width and height must lie in [8, 8192]");
  }
}

void read_coverage(const Reader& r, const toml::table& root, ExperimentSpec& spec) {
  if (const toml::table* cov = root["coverage"].as_table()) {
    r.only(*cov, {"steps"}, "[coverage]");
    if (auto n = (*cov)["steps"])
      spec.coverage_steps =
          r.list(*n.node(), [&](const toml::node& v) { return r.integer(v, "coverage.steps"); });
  }
}

// Scene files are relative to the experiment file's folder.
void resolve_scene_paths(ExperimentSpec& spec) {
  for (std::string& scene : spec.scenes)
    if (!text::starts_with(scene, "builtin:") && std::filesystem::path(scene).is_relative())
      scene = (std::filesystem::path(spec.path).parent_path() / scene).lexically_normal().string();
}

}  // namespace

ExperimentSpec read_experiment(const std::string& path) {
  const toml::table root = parse_toml(path);
  const Reader r(path);
  r.only(root,
         {"name", "description", "scenes", "subdiv", "element_size", "solvers", "seeds",
          "solver_seeds", "repeats", "form_factors", "patches", "budget", "checkpoints",
          "parameters", "images", "coverage"},
         "the experiment");
  ExperimentSpec spec;
  spec.path = path;
  read_name(r, root, spec);
  read_scenes(r, root, spec);
  read_meshes(r, root, spec);
  const bool all_solvers = read_solvers(r, root, spec);
  read_seeds(r, root, spec);
  read_form_factors(r, root, spec);
  read_patches(r, root, spec);
  if (all_solvers) narrow_all_solvers(spec);
  read_budget(r, root, spec);
  read_checkpoints(r, root, spec);
  read_parameters(r, root, spec);
  read_solver_seeds(r, root, spec);
  apply_solver_seeds(r, root, spec);
  read_images(r, root, spec);
  read_coverage(r, root, spec);
  resolve_scene_paths(spec);
  return spec;
}

std::string scene_label(const std::string& scene) {
  if (text::starts_with(scene, "builtin:")) return scene.substr(8);
  return std::filesystem::path(scene).stem().string();
}

std::string make_run_id(const std::string& solver, const std::string& problem_label,
                        const std::map<std::string, std::string>& parameters) {
  std::string id = solver + "/" + problem_label;
  for (const auto& [k, v] : parameters) id += "/" + k + ":" + v;
  return id;
}

std::string make_configuration(const std::string& solver, const std::string& problem_label,
                               std::map<std::string, std::string> parameters) {
  parameters.erase("seed");
  return make_run_id(solver, problem_label, parameters);
}

namespace {

// All combinations of the parameter axes, keys in order.
std::vector<std::map<std::string, std::string>> combinations(
    const std::map<std::string, std::vector<std::string>>& axes) {
  std::vector<std::map<std::string, std::string>> out = {{}};
  for (const auto& [key, values] : axes) {
    std::vector<std::map<std::string, std::string>> next;
    for (const auto& partial : out)
      for (const std::string& v : values) {
        auto m = partial;
        m[key] = v;
        next.push_back(std::move(m));
      }
    out = std::move(next);
  }
  return out;
}

}  // namespace

SweepPlan plan_sweep(const ExperimentSpec& spec) {
  SweepPlan plan;
  const std::vector<long long> seeds =
      spec.seeds.empty() ? std::vector<long long>{-1} : spec.seeds;  // -1: method default
  // Counted in double before anything is built: three 1,000-value axes are 10^9 runs.
  double per_problem = 0.0;
  for (const SolverSweep& solver : spec.solvers) {
    double product = 1.0;
    for (const auto& [key, values] : solver.parameters) product *= double(values.size());
    per_problem += product;
  }
  const double runs =
      double(spec.scenes.size()) * double(spec.meshes.size()) * double(seeds.size()) * per_problem;
  check_limit("runs", runs, spec.path + ": the experiment plans");
  // Images: every run writes, at every image step, the display image and (with error_maps) two
  // error maps, each as float RGB EXR (12 bytes a pixel) and PNG (at most ~3 bytes a pixel).
  const double image_bytes = runs * double(spec.images.steps.size()) *
                             (spec.images.error_maps ? 3.0 : 1.0) * double(spec.images.width) *
                             double(spec.images.height) * 15.0;
  check_limit("images_gb", image_bytes, spec.path + ": the images of the sweep");
  for (const std::string& scene : spec.scenes)
    for (const MeshOptions& mesh : spec.meshes)
      for (long long seed : seeds) {
        PlannedProblem problem;
        problem.spec.scene = scene;
        problem.spec.mesh = mesh;
        problem.spec.ff_method = spec.ff_method;
        for (const auto& [k, v] : spec.ff_parameters) problem.spec.ff_set.push_back(k + "=" + v);
        if (seed >= 0) problem.spec.ff_set.push_back("seed=" + std::to_string(seed));
        problem.spec.precision = spec.precision;
        problem.spec.row_mode = spec.row_mode;
        problem.spec.patches = spec.patches;
        problem.label = "scene:" + scene_label(scene);
        if (spec.meshes.size() > 1)
          problem.label += mesh.element_size > 0
                               ? "/element_size:" + text::format_double(mesh.element_size)
                               : "/subdiv:" + std::to_string(mesh.subdivisions);
        if (seeds.size() > 1) problem.label += "/seed:" + std::to_string(seed);
        plan.problems.push_back(problem);
        const size_t problem_index = plan.problems.size() - 1;
        for (const SolverSweep& solver : spec.solvers)
          for (const auto& parameters : combinations(solver.parameters)) {
            PlannedRun run;
            run.index = plan.runs.size();
            run.problem = problem_index;
            run.solver = solver.name;
            run.parameters = parameters;
            run.run_id = make_run_id(solver.name, problem.label, parameters);
            run.configuration = make_configuration(solver.name, problem.label, parameters);
            plan.runs.push_back(std::move(run));
          }
      }
  // Different entries can still spell the same run id (two scene files with the same name in
  // different folders): such runs would overwrite each other's outputs.
  std::set<std::string> ids;
  for (const PlannedRun& run : plan.runs)
    if (!ids.insert(run.run_id).second)
      throw InputError(spec.path + ": two runs would have the run id '" + run.run_id +
                       "' and overwrite each other (scene files with the same name?)");
  return plan;
}

}  // namespace radlab
