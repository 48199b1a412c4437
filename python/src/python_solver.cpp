// Solvers written in Python (radlab.Solver, python/radlab/solver.py) as radlab::Solver objects:
// registered in the solver registry like a plugin's (register_solver), so execute_run, the
// runner, the metrics, the trace and sweeps treat them exactly as the built-in ones.
//
// The runner calls the solver without the GIL; each call into Python takes it for its duration.
// The Python side sees the System through a SystemView: sizes, areas, reflectance, emission (as
// (n, channels) float64 copies) and rows of F (float64 copies, each counted as one row and n
// pair evaluations, as a C++ solver's with_row counts them). What a step costs at the boundary
// is measured in docs/python.md.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <variant>

#include "core/error.h"
#include "python/src/arrays.h"
#include "python/src/bindings.h"
#include "solvers/registry.h"

namespace py = pybind11;

namespace radlab::python {
namespace {

// The System of the current run, as Python sees it; detached (system = null) when the run's
// solver is destroyed, so a view kept after the run raises instead of reading freed memory.
struct SystemView {
  const System* system = nullptr;

  const System& get() const {
    if (!system) throw py::value_error("this System belongs to a finished run");
    return *system;
  }
};

// (n, channels) float64 copy of a per-element field.
py::array_t<double> channels_array(const Radiosity& field) {
  const size_t n = field.size();
  const int channels = field.channels();
  py::array_t<double> out({py::ssize_t(n), py::ssize_t(channels)});
  auto w = out.mutable_unchecked<2>();
  for (int c = 0; c < channels; ++c)
    for (size_t i = 0; i < n; ++i) w(i, c) = field.at(c, i);
  return out;
}

size_t checked_index(long long i, size_t n, const char* what) {
  if (i < 0 || size_t(i) >= n)
    throw py::index_error(std::string(what) + " " + std::to_string(i) + " out of range [0, " +
                          std::to_string(n) + ")");
  return size_t(i);
}

// Row i of F (or shooter p's row) as a float64 copy; counted by the System as it counts a C++
// solver's.
py::array_t<double> row_copy(const SystemView& view, long long i, bool shooter) {
  const System& system = view.get();
  const size_t n = system.size();
  const size_t index =
      checked_index(i, shooter ? system.shooters().size() : n, shooter ? "shooter" : "element");
  py::array_t<double> out(py::ssize_t{static_cast<py::ssize_t>(n)});
  double* target = out.mutable_data();
  auto copy = [&](const auto* row) {
    for (size_t j = 0; j < n; ++j) target[j] = double(row[j]);
  };
  if (shooter)
    system.with_shooter_row(index, copy);
  else
    system.with_row(index, copy);
  return out;
}

class PythonSolver final : public Solver {
 public:
  PythonSolver(py::object instance, std::string name, SolverKind kind)
      : instance_(std::move(instance)), name_(std::move(name)), kind_(kind) {}

  ~PythonSolver() override {
    // Destroyed by the runner's caller, possibly without the GIL (a run unwinding).
    py::gil_scoped_acquire gil;
    if (view_) view_->system = nullptr;
    view_object_ = py::object();
    instance_ = py::object();
  }

  void init(const System& system) override {
    py::gil_scoped_acquire gil;
    n_ = system.size();
    channels_ = system.channels();
    auto view = std::make_unique<SystemView>();
    view->system = &system;
    view_ = view.get();
    view_object_ = py::cast(std::move(view));
    keep_python_errors([&] { instance_.attr("init")(view_object_); });
  }

  StepInfo step() override {
    py::gil_scoped_acquire gil;
    py::object finished = keep_python_errors([&] { return instance_.attr("step")(); });
    StepInfo info;
    info.finished =
        keep_python_errors([&] { return !finished.is_none() && finished.cast<bool>(); });
    return info;
  }

  const Radiosity& solution() const override {
    py::gil_scoped_acquire gil;
    solution_ = keep_python_errors([&] {
      return radiosity_from(instance_.attr("solution")(), n_, channels_, name_ + ".solution()");
    });
    return solution_;
  }

  const Radiosity* unshot() const override {
    if (kind_ != SolverKind::kShooting) return nullptr;
    py::gil_scoped_acquire gil;
    unshot_ = keep_python_errors([&] {
      return radiosity_from(instance_.attr("unshot")(), n_, channels_, name_ + ".unshot()");
    });
    return &unshot_;
  }

  std::vector<std::pair<std::string, double>> statistics() const override {
    py::gil_scoped_acquire gil;
    return keep_python_errors([&] {
      std::vector<std::pair<std::string, double>> out;
      py::object stats = instance_.attr("statistics")();
      if (stats.is_none()) return out;
      for (auto item : py::reinterpret_borrow<py::dict>(stats))
        out.emplace_back(py::str(item.first).cast<std::string>(), item.second.cast<double>());
      return out;
    });
  }

 private:
  py::object instance_;
  std::string name_;
  SolverKind kind_;
  size_t n_ = 0;
  int channels_ = 1;
  SystemView* view_ = nullptr;  // owned by view_object_
  py::object view_object_;
  mutable Radiosity solution_, unshot_;
};

SolverKind kind_of(const std::string& kind) {
  if (kind == "gathering") return SolverKind::kGathering;
  if (kind == "shooting") return SolverKind::kShooting;
  if (kind == "other") return SolverKind::kOther;
  throw UsageError("solver kind must be 'gathering', 'shooting' or 'other', got '" + kind + "'");
}

using Value = std::variant<double, long long, bool, std::string>;

struct PythonParameter {
  std::string name, help;
  Value fallback;
};

// Reads each parameter from the bag with the getter of its default's type (the registry learns
// the defaults from these reads, as from a C++ options struct).
py::dict read_parameters(ParamBag& bag, const std::vector<PythonParameter>& parameters) {
  std::vector<std::pair<std::string, Value>> values;
  for (const PythonParameter& p : parameters) {
    Value v = p.fallback;
    if (auto* d = std::get_if<double>(&p.fallback)) v = bag.get_double(p.name, *d);
    if (auto* i = std::get_if<long long>(&p.fallback)) v = bag.get_int(p.name, *i);
    if (auto* b = std::get_if<bool>(&p.fallback)) v = bag.get_bool(p.name, *b);
    if (auto* s = std::get_if<std::string>(&p.fallback)) v = bag.get_string(p.name, *s);
    values.emplace_back(p.name, v);
  }
  py::dict kwargs;
  for (const auto& [name, v] : values)
    std::visit([&](const auto& x) { kwargs[py::str(name)] = x; }, v);
  return kwargs;
}

void register_python_solver(
    const std::string& name, const std::string& summary, const std::string& reference,
    const std::string& cost, const std::string& kind,
    const std::vector<std::tuple<std::string, py::object, std::string>>& parameter_list,
    py::object factory) {
  SolverInfo info;
  info.name = name;
  info.summary = summary;
  info.reference = reference;
  info.cost = cost;
  info.kind = kind_of(kind);
  std::vector<PythonParameter> parameters;
  for (const auto& [key, fallback, help] : parameter_list) {
    PythonParameter p{key, help, 0.0};
    // bool before int: Python's True is an int too.
    if (py::isinstance<py::bool_>(fallback))
      p.fallback = fallback.cast<bool>();
    else if (py::isinstance<py::int_>(fallback))
      p.fallback = fallback.cast<long long>();
    else if (py::isinstance<py::float_>(fallback))
      p.fallback = fallback.cast<double>();
    else if (py::isinstance<py::str>(fallback))
      p.fallback = fallback.cast<std::string>();
    else
      throw py::type_error("solver '" + name + "': the default of parameter '" + key +
                           "' must be a float, int, bool or str");
    parameters.push_back(p);
    info.parameters.push_back({key, "", help});
  }
  // Never released: the registry lives until the process ends, after the interpreter.
  auto* make_instance = new py::object(std::move(factory));
  const SolverKind solver_kind = info.kind;
  info.make = [name, solver_kind, parameters, make_instance](ParamBag& bag) {
    py::gil_scoped_acquire gil;
    py::dict kwargs = read_parameters(bag, parameters);
    py::object instance = (*make_instance)(**kwargs);
    return std::unique_ptr<Solver>(std::make_unique<PythonSolver>(instance, name, solver_kind));
  };
  register_solver(std::move(info));
}

}  // namespace

void bind_python_solver(py::module_& m) {
  py::class_<SystemView>(m, "System", "The system a solver runs on (radlab.Solver.init)")
      .def_property_readonly("size", [](const SystemView& v) { return v.get().size(); })
      .def_property_readonly("channels", [](const SystemView& v) { return v.get().channels(); })
      .def_property_readonly("shooters",
                             [](const SystemView& v) { return v.get().shooters().size(); })
      .def_property_readonly("area",
                             [](const SystemView& v) {
                               const auto a = v.get().area();
                               return py::array_t<double>(py::ssize_t(a.size()), a.data());
                             })
      .def_property_readonly(
          "rho", [](const SystemView& v) { return channels_array(v.get().reflectance()); })
      .def_property_readonly("E",
                             [](const SystemView& v) { return channels_array(v.get().emission()); })
      .def(
          "row", [](const SystemView& v, long long i) { return row_copy(v, i, false); },
          py::arg("i"))
      .def(
          "shooter_row", [](const SystemView& v, long long p) { return row_copy(v, p, true); },
          py::arg("p"))
      .def(
          "charge_pair_evaluations",
          [](const SystemView& v, long long pairs) {
            if (pairs < 0) throw py::value_error("pairs must be >= 0");
            v.get().charge_pair_evaluations(uint64_t(pairs));
          },
          py::arg("pairs"))
      .def(
          "charge_rays",
          [](const SystemView& v, long long rays) {
            if (rays < 0) throw py::value_error("rays must be >= 0");
            v.get().charge_rays(uint64_t(rays));
          },
          py::arg("rays"))
      .def_property_readonly("rows_used", [](const SystemView& v) { return v.get().rows_used(); })
      .def_property_readonly("pair_evaluations",
                             [](const SystemView& v) { return v.get().pair_evaluations(); })
      .def_property_readonly("rays_used", [](const SystemView& v) { return v.get().rays_used(); });

  m.def("register_solver", &register_python_solver, py::arg("name"), py::arg("summary"),
        py::arg("reference"), py::arg("cost"), py::arg("kind"), py::arg("parameters"),
        py::arg("factory"));
}

}  // namespace radlab::python
