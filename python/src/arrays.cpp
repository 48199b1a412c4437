// numpy conversions (arrays.h).
#include "python/src/arrays.h"

#include <cmath>

namespace py = pybind11;

namespace radlab::python {
namespace {

std::string type_name(py::handle value) {
  return py::str(py::type::of(value).attr("__name__")).cast<std::string>();
}

std::string shape_text(const py::array& a) {
  std::string text = "(";
  for (py::ssize_t d = 0; d < a.ndim(); ++d) text += (d ? ", " : "") + std::to_string(a.shape(d));
  return text + (a.ndim() == 1 ? ",)" : ")");
}

// The value as a float64 numpy array, or a TypeError saying what it is instead.
py::array checked_float64(py::handle value, const std::string& what, const std::string& expected) {
  if (!py::isinstance<py::array>(value))
    throw py::type_error(what + ": expected " + expected + ", got " + type_name(value) +
                         " (convert with numpy.asarray(x, dtype=numpy.float64))");
  py::array a = py::reinterpret_borrow<py::array>(value);
  if (!a.dtype().is(py::dtype::of<double>()))
    throw py::type_error(what + ": expected " + expected + ", got dtype " +
                         py::str(a.dtype()).cast<std::string>() +
                         " (radlab computes in float64; convert with x.astype(numpy.float64))");
  return a;
}

void check_finite(double v, const std::string& what, size_t element, int channel) {
  if (!std::isfinite(v))
    throw py::value_error(what + ": element " + std::to_string(element) + ", channel " +
                          std::to_string(channel) + " is " + std::to_string(v) +
                          " (every value must be finite)");
}

}  // namespace

py::array_t<double> rgb_array(const Radiosity& field) {
  const size_t n = field.size();
  py::array_t<double> out({py::ssize_t(n), py::ssize_t(3)});
  auto w = out.mutable_unchecked<2>();
  for (size_t i = 0; i < n; ++i) {
    const auto rgb = field.rgb(i);
    w(i, 0) = rgb.x, w(i, 1) = rgb.y, w(i, 2) = rgb.z;
  }
  return out;
}

py::array_t<double> read_only_view(std::span<const double> values, py::handle owner) {
  py::array_t<double> view({py::ssize_t(values.size())}, {py::ssize_t(sizeof(double))},
                           values.data(), owner);
  // Writing into radlab's own arrays would change a prepared problem behind its back.
  py::detail::array_proxy(view.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return view;
}

Radiosity radiosity_from(py::handle value, size_t n, int channels, const std::string& what) {
  const std::string expected = "a numpy float64 array of shape (" + std::to_string(n) +
                               (channels == 1 ? ",) or (" + std::to_string(n) + ", 3)" : ", 3)");
  py::array a = checked_float64(value, what, expected);
  const bool column = a.ndim() == 1 && size_t(a.shape(0)) == n && channels == 1;
  const bool table = a.ndim() == 2 && size_t(a.shape(0)) == n &&
                     (a.shape(1) == 3 || (a.shape(1) == 1 && channels == 1));
  if (!column && !table)
    throw py::value_error(what + ": expected " + expected + ", got shape " + shape_text(a));
  Radiosity field(channels, n);
  if (column) {
    auto r = py::array_t<double>(a).unchecked<1>();
    for (size_t i = 0; i < n; ++i) check_finite(field.at(0, i) = r(i), what, i, 0);
    return field;
  }
  auto r = py::array_t<double>(a).unchecked<2>();
  const py::ssize_t columns = r.shape(1);
  for (size_t i = 0; i < n; ++i) {
    for (py::ssize_t c = 0; c < columns; ++c) check_finite(r(i, c), what, i, int(c));
    if (channels == 3) {
      for (int c = 0; c < 3; ++c) field.at(c, i) = r(i, c);
    } else {
      // A grey system: three equal columns (as rgb_array gives) or one.
      if (columns == 3 && (r(i, 1) != r(i, 0) || r(i, 2) != r(i, 0)))
        throw py::value_error(what + ": the scene is grey (one channel) but element " +
                              std::to_string(i) + " has different values per column");
      field.at(0, i) = r(i, 0);
    }
  }
  return field;
}

void vector_from(py::handle value, size_t n, const std::string& what, std::span<double> out) {
  const std::string expected = "a numpy float64 array of shape (" + std::to_string(n) + ",)";
  py::array a = checked_float64(value, what, expected);
  if (a.ndim() != 1 || size_t(a.shape(0)) != n)
    throw py::value_error(what + ": expected " + expected + ", got shape " + shape_text(a));
  auto r = py::array_t<double>(a).unchecked<1>();
  for (size_t i = 0; i < n; ++i) check_finite(out[i] = r(i), what, i, 0);
}

}  // namespace radlab::python
