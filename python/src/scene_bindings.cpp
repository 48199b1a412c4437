// radlab.load's C++ side: a SceneHandle from the command line's scene options, its arrays (areas
// as a zero-copy view; centroids, normals, reflectance and emission as (n, 3) copies), the
// form-factor matrix of any registered method as CSR arrays with its diagnostics, and the
// certified reference. Long work (loading, meshing, matrices, references) runs without the GIL.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>

#include "core/text.h"
#include "experiments/problem/problem_options.h"
#include "metrics/error_metrics.h"
#include "python/src/arrays.h"
#include "python/src/bindings.h"
#include "python/src/scene_handle.h"
#include "scene/scene_loader.h"

namespace py = pybind11;

namespace radlab::python {

SceneHandle::SceneHandle(const ProblemSpec& spec) : spec_(spec) {
  ProblemSpec load = spec;
  // What `radlab formfactors` does before it computes anything: the scene, mesh and method,
  // without a matrix or reference (a scene without a light may still be looked at).
  load.need_reference = false;
  load.require_emitter = false;
  load.row_mode = RowMode::kOnTheFly;
  load.patches = PatchOptions{};
  loaded_ = prepare_problem(load);
}

const Problem& SceneHandle::run_problem(const ReferenceChoice& reference, const Budget& budget) {
  // prepare_run_problem reads only the reference choice and whether a tolerance is asked for.
  const std::string key = reference.kind + "|" + text::format_double(reference.feps) + "|" +
                          text::format_double(reference.aeps) + (budget.tol ? "|tol" : "");
  std::unique_ptr<Problem>& problem = prepared_[key];
  if (!problem) problem = prepare_run_problem(spec_, reference, budget);
  return *problem;
}

namespace {

// One (n, 3) copy of per-element vectors (centroids, normals).
py::array_t<double> vec3_array(const std::vector<Vec3>& values) {
  py::array_t<double> out({py::ssize_t(values.size()), py::ssize_t(3)});
  auto w = out.mutable_unchecked<2>();
  for (size_t i = 0; i < values.size(); ++i)
    for (int c = 0; c < 3; ++c) w(i, c) = values[i][c];
  return out;
}

// The element-by-element matrix as CSR arrays (indptr, indices, data) of its nonzero entries, in
// double: the method's matrix as computed (certified_matrix()), whatever the solvers' storage.
py::dict csr_of(const FormFactorMatrix& matrix) {
  const size_t n = matrix.size();
  std::vector<long long> indptr(n + 1, 0);
  std::vector<int> indices;
  std::vector<double> data;
  {
    LongWork work;  // GIL released, Ctrl-C checked
    for (size_t i = 0; i < n; ++i) {
      matrix.visit_row(i, [&](const auto* row) {
        for (size_t j = 0; j < n; ++j)
          if (row[j] != 0) {
            indices.push_back(int(j));
            data.push_back(double(row[j]));
          }
      });
      indptr[i + 1] = static_cast<long long>(data.size());
    }
  }
  py::dict csr;
  csr["n"] = n;
  csr["indptr"] = py::array_t<long long>(py::ssize_t(indptr.size()), indptr.data());
  csr["indices"] = py::array_t<int>(py::ssize_t(indices.size()), indices.data());
  csr["data"] = py::array_t<double>(py::ssize_t(data.size()), data.data());
  return csr;
}

// The diagnostics of the matrix returned (diagnose() on it: the numbers describe exactly what
// Python gets), the method's row-sum check, and the same of the matrix as the method computed it
// (before any symmetrisation).
py::dict diagnostics_of(const Problem& problem, const FormFactorMatrix& returned) {
  auto fill = [](py::dict& out, const MatrixDiagnostics& d) {
    out["row_sum_min"] = d.row_sum_min;
    out["row_sum_max"] = d.row_sum_max;
    out["reciprocity_defect"] = d.reciprocity_defect;
    out["reciprocity_defect_relative"] = d.reciprocity_defect_relative;
    out["negative_entries"] = d.negative_entries;
    out["non_finite_entries"] = d.non_finite_entries;
    out["nonzero_entries"] = d.nonzero_entries;
    out["summary"] = d.summary();
  };
  const RowSumCheck& r = problem.row_sums;
  py::dict out;
  out["method"] = problem.spec.ff_method;
  out["parameters"] = problem.ff_parameters;
  fill(out, diagnose(returned, problem.mesh.area));
  out["stated_row_sum_error"] = r.stated_error;
  out["rows_above_stated_error"] = r.rows_above;
  out["row_sum_check"] = r.headline();
  py::dict computed;
  fill(computed, problem.raw_diagnostics);
  out["as_computed"] = computed;
  out["cache_file"] = problem.matrix_cache_file;
  return out;
}

py::dict reference_of(const Reference& ref) {
  py::dict out;
  out["B"] = rgb_array(ref.B);
  out["bound"] = ref.bound_inf;
  out["bound_relative"] = ref.bound_relative;
  out["residual"] = ref.residual_inf;
  out["inverse_norm_bound"] = ref.inverse_norm_bound;
  out["q"] = ref.q;
  out["spectral_radius_upper"] = ref.spectral_radius_upper;
  out["float_storage_bound"] = ref.float_storage_bound;
  out["float_storage_bound_relative"] = ref.float_storage_bound_relative;
  out["method"] = ref.method;
  out["kind"] = ref.kind;
  out["system"] = ref.system;
  out["summary"] = ref.summary();
  return out;
}

// The problem with the certified reference (what `radlab reference` computes), prepared once.
const Problem& certified_problem(SceneHandle& scene) {
  LongWork work;  // GIL released, Ctrl-C checked
  return scene.run_problem(ReferenceChoice{}, Budget{});
}

}  // namespace

void bind_scene(py::module_& m) {
  m.def("set_mgf_include_root", &set_mgf_include_root, py::arg("folder"));

  py::class_<SceneHandle>(m, "SceneHandle")
      .def(py::init([](const std::string& scene, int subdiv, double element_size,
                       const std::string& patches, double patch_size, const std::string& patch_rows,
                       bool keep_overlaps, const std::string& ff_method,
                       const std::vector<std::string>& ff_set, const std::string& precision,
                       const std::string& ff_mode, bool cache, const std::string& cache_dir) {
             // The command line's options, read by the one function the CLI uses.
             ProblemSpec spec =
                 make_problem_spec(SceneOptions{scene, subdiv, element_size, patches, patch_size,
                                                patch_rows, keep_overlaps},
                                   FormFactorOptions{ff_method, ff_set, precision, ff_mode});
             spec.use_cache = cache;
             spec.cache_dir = cache_dir;
             LongWork work;  // GIL released, Ctrl-C checked
             return std::make_unique<SceneHandle>(spec);
           }),
           py::arg("scene"), py::arg("subdiv"), py::arg("element_size"), py::arg("patches"),
           py::arg("patch_size"), py::arg("patch_rows"), py::arg("keep_overlaps"),
           py::arg("ff_method"), py::arg("ff_set"), py::arg("precision"), py::arg("ff_mode"),
           py::arg("cache"), py::arg("cache_dir"))
      .def_property_readonly("name", [](const SceneHandle& s) { return s.loaded().scene().name; })
      .def_property_readonly("size", [](const SceneHandle& s) { return s.loaded().mesh.size(); })
      .def_property_readonly(
          "polygons", [](const SceneHandle& s) { return s.loaded().scene().polygons.size(); })
      .def_property_readonly("channels",
                             [](const SceneHandle& s) { return s.loaded().system->channels(); })
      .def_property_readonly("areas",
                             [](py::object self) {
                               const SceneHandle& s = self.cast<const SceneHandle&>();
                               return read_only_view(s.loaded().mesh.area, self);
                             })
      .def_property_readonly(
          "centroids", [](const SceneHandle& s) { return vec3_array(s.loaded().mesh.centroid); })
      .def_property_readonly(
          "normals", [](const SceneHandle& s) { return vec3_array(s.loaded().mesh.normal); })
      .def_property_readonly("polygon_of_element",
                             [](const SceneHandle& s) {
                               const auto& p = s.loaded().mesh.polygon;
                               return py::array_t<uint32_t>(py::ssize_t(p.size()), p.data());
                             })
      .def_property_readonly(
          "rho", [](const SceneHandle& s) { return rgb_array(s.loaded().system->reflectance()); })
      .def_property_readonly(
          "E", [](const SceneHandle& s) { return rgb_array(s.loaded().system->emission()); })
      .def(
          "form_factors",
          [](const SceneHandle& s, const std::string& method, const std::vector<std::string>& set) {
            ProblemSpec spec = s.spec();
            spec.ff_method = method;
            spec.ff_set = set;
            spec.patches = PatchOptions{};
            spec.row_mode = RowMode::kCached;
            // The method's F in double, as the certified reference reads it (with float storage
            // only the solvers' float rounding would be kept without a reference).
            spec.precision = Precision::kDouble;
            spec.need_reference = false;
            spec.require_emitter = false;
            std::unique_ptr<Problem> problem;
            {
              LongWork work;  // GIL released, Ctrl-C checked
              problem = prepare_problem(spec);
            }
            const FormFactorMatrix& matrix = problem->certified_matrix();
            py::dict out = csr_of(matrix);
            out["diagnostics"] = diagnostics_of(*problem, matrix);
            return out;
          },
          py::arg("method"), py::arg("set"))
      .def("reference",
           [](SceneHandle& s) { return reference_of(*certified_problem(s).reference); })
      .def(
          "errors",
          [](SceneHandle& s, py::handle B) {
            const Problem& problem = certified_problem(s);
            const Radiosity b =
                radiosity_from(B, problem.mesh.size(), problem.system->channels(), "B");
            const ErrorMetrics e =
                compare(b, problem.reference->B, problem.mesh.area, kMeanOfChannels);
            py::dict out;
            out["rms"] = e.rms;
            out["rms_rel"] = e.rms_rel;
            out["p_mean"] = e.p_mean;
            out["p_rms"] = e.p_rms;
            out["p_max"] = e.p_max;
            // ||B - B*||_inf / max B*, B* the certified reference (its bound is far below).
            double worst = 0.0, largest = 0.0;
            for (int c = 0; c < b.channels(); ++c)
              for (size_t i = 0; i < b.size(); ++i) {
                worst = std::max(worst, std::abs(b.at(c, i) - problem.reference->B.at(c, i)));
                largest = std::max(largest, std::abs(problem.reference->B.at(c, i)));
              }
            out["max_relative"] = largest > 0 ? worst / largest : worst;
            return out;
          },
          py::arg("B"));
}

}  // namespace radlab::python
