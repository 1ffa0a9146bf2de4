// The Python module digilap._digilap (pybind11): the C++ pipeline with NumPy arrays in and
// NumPy/SciPy out. The operator's CSR arrays and element arrays are handed to NumPy as views on
// the C++ operator's memory (each view keeps the operator alive), never copied. The GIL is
// released around every call that computes. The pure-Python layer (digilap/__init__.py,
// digilap/surface.py) adds the one-call laplacian() and the docstrings' conventions. The
// bindings mirror the library's layers: core.cpp, curve.cpp, surface.cpp.
#include "common.hpp"

PYBIND11_MODULE(_digilap, m) {
  m.doc() = "digilap: a convergent Laplace-Beltrami operator on the boundary of digitized shapes (C++ core).";
  digilap::python::bind_core(m);
  digilap::python::bind_curve(m);
  py::module_ s = m.def_submodule("surface", "Digital surfaces in 3D: the same operator on the surfels of a voxel set.");
  digilap::python::bind_surface(m, s);
}
