// Shared by the binding's files (python/core.cpp, curve.cpp, surface.cpp, module.cpp): file
// names from Python, the GIL guard, and NumPy / SciPy views on the operators' memory.
#pragma once

#include "digilap/core/io.hpp"
#include "digilap/core/operator.hpp"
#include "digilap/core/spectrum.hpp"

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>
#include <utility>
#include <vector>

namespace py = pybind11;

// A file or directory name from Python: a str or any os.PathLike (pathlib.Path), as open() takes.
struct FilePath {
  std::string value;
};

namespace pybind11::detail {
template <>
struct type_caster<FilePath> {
  PYBIND11_TYPE_CASTER(FilePath, const_name("os.PathLike | str"));
  bool load(handle source, bool) {
    if (!PyUnicode_Check(source.ptr()) && !PyObject_HasAttrString(source.ptr(), "__fspath__")) return false;
    object text = reinterpret_steal<object>(PyOS_FSPath(source.ptr()));
    if (!text || !PyUnicode_Check(text.ptr())) {
      PyErr_Clear();
      return false;
    }
    value.value = text.cast<std::string>();
    return true;
  }
};
}  // namespace pybind11::detail

namespace digilap::python {

using Release = py::call_guard<py::gil_scoped_release>;

// A NumPy view on `count` elements at `data`, kept alive by `owner` (a Python object holding
// the C++ memory). A 1-D view on a 1-element ndarray base would make SciPy copy ("a view of a
// much larger array" is pruned): the base is an ndarray of the same size, itself kept alive
// by the owner.
template <class T>
py::array view(const T* data, std::vector<py::ssize_t> shape, py::handle owner) {
  py::array_t<T> a(shape, data, owner);
  a.attr("flags").attr("writeable") = false;
  return std::move(a);
}

// One of the operator's matrices as scipy.sparse.csr_matrix over its own arrays.
// The eigen-solvers' options a binding takes: count, tolerance and max_iterations as keywords
// with SpectrumOptions' defaults (tolerance_argument(), max_iterations_argument()), the rest at
// their defaults.
inline digilap::SpectrumOptions spectrum_options(int count, double tolerance, int max_iterations) {
  digilap::SpectrumOptions o;
  o.count = count;
  o.tolerance = tolerance;
  o.max_iterations = max_iterations;
  return o;
}
inline py::arg_v tolerance_argument() { return py::arg("tolerance") = digilap::SpectrumOptions{}.tolerance; }
inline py::arg_v max_iterations_argument() { return py::arg("max_iterations") = digilap::SpectrumOptions{}.max_iterations; }

inline py::object csr_view(const SparseMatrix& m, py::handle owner) {
  if (m.rows() == 0) return py::none();
  const auto n = static_cast<py::ssize_t>(m.rows()), nnz = static_cast<py::ssize_t>(m.nonZeros());
  py::array data = view(m.valuePtr(), {nnz}, owner), indices = view(m.innerIndexPtr(), {nnz}, owner),
            indptr = view(m.outerIndexPtr(), {n + 1}, owner);
  // digilap._views.OperatorMatrix: a csr_matrix whose in-place methods say to take a copy.
  py::object csr = py::module_::import("digilap._views").attr("OperatorMatrix");
  return csr(py::make_tuple(data, indices, indptr), py::arg("shape") = py::make_tuple(n, n), py::arg("copy") = false);
}

/// save_operator's format argument: "mtx" (Matrix Market) or "npz", else a ValueError.
inline FileFormat file_format_of(const std::string& format) {
  if (format != "mtx" && format != "npz") throw py::value_error("format: expected 'mtx' or 'npz', got '" + format + "'");
  return format == "npz" ? FileFormat::Npz : FileFormat::MatrixMarket;
}

/// The bindings of each layer, in the order module.cpp calls them: the core first (HeatOperator
/// is the base of the curve and surface operators), then curves into the module, surfaces into
/// the submodule digilap.surface.
void bind_core(py::module_& m);
void bind_curve(py::module_& m);
void bind_surface(py::module_& m, py::module_& s);

}  // namespace digilap::python
