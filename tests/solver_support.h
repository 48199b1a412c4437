// Fixtures shared by the solver tests (tests/solvers/: the conformance, shooting, interleaving,
// gathering and orderings tests): a scene with its mesh, raycast matrix, System
// and certified reference, and the residuals and error norms the tests assert on.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "formfactor/methods/raycast.h"
#include "scene/builtin/builtin_scenes.h"
#include "scene/validate.h"
#include "solvers/reference/reference.h"
#include "solvers/registry.h"

namespace radlab::testing {
struct Setup {
  Scene scene;
  Mesh mesh;
  FormFactorMatrix matrix;
  std::unique_ptr<System> system;
  Reference reference;

  size_t n() const { return mesh.size(); }
  int channels() const { return system->channels(); }
  std::span<const double> area() const { return system->area(); }
};

// The scene's system and certified reference, with the form factors of the method that
// `make_method(scene, mesh)` returns.
template <class MakeMethod>
std::unique_ptr<Setup> setup_scene_with(Scene scene, int subdiv, Precision precision,
                                        bool symmetrised, MakeMethod&& make_method) {
  auto s = std::make_unique<Setup>();
  s->scene = std::move(scene);
  validate_scene(s->scene);
  s->mesh = build_mesh(s->scene, {subdiv, 0.0});
  const auto ff = make_method(s->scene, s->mesh);
  BuildReport report;
  s->matrix = build_matrix(*ff, s->mesh.size(), precision, report);
  if (symmetrised) symmetrise(s->matrix, s->mesh.area);
  s->system = std::make_unique<System>(s->scene, s->mesh, s->matrix);
  s->reference = compute_reference(*s->system, s->matrix);
  return s;
}

// The same with raycast form factors (4 rays per pair).
inline std::unique_ptr<Setup> setup_scene(Scene scene, int subdiv,
                                          Precision precision = Precision::kFloat,
                                          bool symmetrised = false) {
  return setup_scene_with(std::move(scene), subdiv, precision, symmetrised,
                          [](const Scene& sc, const Mesh& mesh) {
                            RaycastOptions options;
                            options.rays = 4;
                            return std::make_unique<RaycastFormFactors>(sc, mesh, options);
                          });
}

inline std::unique_ptr<Setup> setup(const std::string& spec, int subdiv,
                                    Precision precision = Precision::kFloat,
                                    bool symmetrised = false) {
  return setup_scene(make_builtin_scene(spec), subdiv, precision, symmetrised);
}

inline std::unique_ptr<Solver> make(const std::string& name,
                                    const std::vector<std::string>& params = {}) {
  ParamBag bag = ParamBag::from_assignments(params, "solver '" + name + "'");
  return make_solver(name, bag);
}

inline double max_relative_error(const Radiosity& B, const Radiosity& ref) {
  double worst = 0.0;
  for (int c = 0; c < ref.channels(); ++c)
    for (size_t i = 0; i < ref.size(); ++i)
      worst = std::max(worst, std::abs(B.at(c, i) - ref.at(c, i)) / std::abs(ref.at(c, i)));
  return worst;
}

inline double max_abs(const Radiosity& v) {
  double m = 0.0;
  for (double x : v.raw()) m = std::max(m, std::abs(x));
  return m;
}

inline Radiosity minus(const Radiosity& a, const Radiosity& b) {
  Radiosity d = a;
  for (size_t k = 0; k < d.raw().size(); ++k) d.raw()[k] -= b.raw()[k];
  return d;
}

// E + J' x - x with J'_jk = rho_j F_kj A_k / A_j (the operator a shot applies; long double).
inline Radiosity shooting_residual(const Setup& s, const Radiosity& x) {
  const System& sys = *s.system;
  Radiosity r(x.channels(), x.size());
  for (int c = 0; c < x.channels(); ++c)
    for (size_t j = 0; j < x.size(); ++j) {
      long double in = 0.0L;
      for (size_t k = 0; k < x.size(); ++k)
        in += static_cast<long double>(s.matrix.at(k, j)) * sys.area()[k] * x.at(c, k);
      const long double rho = sys.reflectance().at(c, j);
      r.at(c, j) = double(sys.emission().at(c, j) + rho * in / sys.area()[j] - x.at(c, j));
    }
  return r;
}

// E + J x - x, the System's own residual (long double).
inline Radiosity gathering_residual(const Setup& s, const Radiosity& x) {
  const System& sys = *s.system;
  Radiosity r(x.channels(), x.size());
  for (int c = 0; c < x.channels(); ++c)
    for (size_t i = 0; i < x.size(); ++i) {
      long double g = 0.0L;
      for (size_t j = 0; j < x.size(); ++j)
        g += static_cast<long double>(s.matrix.at(i, j)) * x.at(c, j);
      r.at(c, i) = double(sys.emission().at(c, i) + sys.reflectance().at(c, i) * g - x.at(c, i));
    }
  return r;
}

// Runs until `rows` form-factor rows are used (counting from now) or the solver finishes.
inline void run_rows(Solver& solver, const System& system, uint64_t rows) {
  const uint64_t end = system.rows_used() + rows;
  while (system.rows_used() < end)
    if (solver.step().finished) break;
}

struct Variant {
  std::string solver;
  std::vector<std::string> params;
};

inline std::vector<std::string> split_params(const std::string& spec) {
  std::vector<std::string> out;
  size_t start = 0;
  while (start < spec.size()) {
    size_t comma = spec.find(',', start);
    if (comma == std::string::npos) comma = spec.size();
    out.push_back(spec.substr(start, comma - start));
    start = comma + 1;
  }
  return out;
}

// A gtest parameter name from a solver or variant name ("gauss-seidel" -> "gauss_seidel").
inline std::string test_name(const ::testing::TestParamInfo<std::string>& param) {
  std::string name = param.param;
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return name;
}

}  // namespace radlab::testing
