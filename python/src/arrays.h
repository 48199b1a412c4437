// numpy arrays to and from radlab's per-element values. Outputs are copies in (n, 3) float64
// (a grey field repeats its channel, as `radlab solve --out` writes it) unless a view is asked
// for; inputs from Python are checked strictly (a numpy float64 array of the exact shape, every
// value finite) and refused with a TypeError or ValueError that says what was expected and what
// came, instead of being converted silently.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <span>
#include <string>

#include "core/radiosity.h"

namespace radlab::python {

// (n, 3) float64 copy: row i is field.rgb(i).
pybind11::array_t<double> rgb_array(const Radiosity& field);

// A read-only 1-d view of `values`, kept alive by `owner` (zero-copy).
pybind11::array_t<double> read_only_view(std::span<const double> values, pybind11::handle owner);

// A Radiosity of `channels` channels and n elements from a Python value: a numpy float64 array
// of shape (n,) or (n, 1) for one channel, (n, 3) for three (or for one, when the three columns
// are equal), every value finite. `what` names the value in messages ("MySolver.solution()").
Radiosity radiosity_from(pybind11::handle value, size_t n, int channels, const std::string& what);

// A 1-d float64 numpy array of length n with finite values, copied into `out`.
void vector_from(pybind11::handle value, size_t n, const std::string& what, std::span<double> out);

}  // namespace radlab::python
