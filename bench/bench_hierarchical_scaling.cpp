// Hierarchical radiosity over the scaling family (issue 33): builtin:floors:k=K (patch 1 m, so
// K storeys are ~470 K polygons) for K = 1, 2, 4, 8, 16, with and without clustering; one whole
// solve each, links, refinement tests, rays, seconds and peak RSS as counters. After the runs the
// growth exponents of links, refinement tests and solve time in the polygon count s are fitted
// with the Ceres fit of metrics/power_law_fit.h (log y = log C + p log s, all points, nearly
// least squares) and printed with their 1-sigma uncertainties: Smits
// et al.'s O(s log s) linking against the unclustered O(s^2).
//   build/bench/bench_hierarchical_scaling --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "formfactor/methods/raycast.h"
#include "metrics/power_law_fit.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/validate.h"
#include "solvers/registry.h"

namespace radlab {
namespace {

struct Point {
  double polygons = 0, links = 0, tests = 0, seconds = 0;
};
std::map<std::string, std::vector<Point>>& points() {
  static std::map<std::string, std::vector<Point>> p;
  return p;
}

double peak_rss_mb() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  return 0.0;
}

void BM_Floors(benchmark::State& state, const std::string& clustering) {
  const int k = int(state.range(0));
  Scene scene = make_builtin_scene("floors:k=" + std::to_string(k) + ",patch=1");
  validate_scene(scene);
  const Mesh mesh = build_mesh(scene, {1, 0.0});
  // The System's row source is never read by hierarchical (it evaluates its own factors).
  RaycastFormFactors rows(scene, mesh, RaycastOptions{});
  System system(scene, mesh, rows);
  std::map<std::string, double> stats;
  for (auto _ : state) {
    ParamBag bag("bench");
    bag.set("feps", "0.04");
    bag.set("clustering", clustering);
    auto solver = make_solver("hierarchical", bag);
    solver->init(system);
    while (!solver->step().finished) {
    }
    for (const auto& [key, v] : solver->statistics()) stats[key] = v;
  }
  const double seconds = stats["refinement_seconds"] + stats["gather_seconds"];
  state.counters["polygons"] = double(scene.polygons.size());
  state.counters["links"] = stats["links"];
  state.counters["cluster_links"] = stats["links_with_a_cluster"];
  state.counters["tests"] = stats["refinement_tests"];
  state.counters["rays"] = stats["rays"];
  state.counters["refine_s"] = stats["refinement_seconds"];
  state.counters["gather_s"] = stats["gather_seconds"];
  state.counters["peak_rss_MB"] = peak_rss_mb();
  points()[clustering].push_back(
      {double(scene.polygons.size()), stats["links"], stats["refinement_tests"], seconds});
}

BENCHMARK_CAPTURE(BM_Floors, none, std::string("none"))
    ->RangeMultiplier(2)
    ->Range(1, 16)
    ->Iterations(1)
    ->Unit(benchmark::kSecond);
BENCHMARK_CAPTURE(BM_Floors, isotropic, std::string("isotropic"))
    ->RangeMultiplier(2)
    ->Range(1, 16)
    ->Iterations(1)
    ->Unit(benchmark::kSecond);

void print_exponents() {
  for (const auto& [clustering, list] : points()) {
    std::vector<double> s, links, tests, seconds;
    for (const Point& p : list) {
      s.push_back(p.polygons);
      links.push_back(p.links);
      tests.push_back(p.tests);
      seconds.push_back(p.seconds);
    }
    auto show = [&](const char* what, const std::vector<double>& y) {
      const PowerLawFit fit = fit_power_law(s, y);
      if (fit.valid)
        std::printf("clustering=%s: %s ~ s^%.3f +- %.3f (%d points)\n", clustering.c_str(), what,
                    fit.exponent, fit.exponent_sigma, fit.points);
      else
        std::printf("clustering=%s: %s: no fit (%s)\n", clustering.c_str(), what,
                    fit.reason.c_str());
    };
    show("links", links);
    show("refinement tests", tests);
    show("solve seconds", seconds);
  }
}

}  // namespace
}  // namespace radlab

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  radlab::print_exponents();
  return 0;
}
