// The Python module digilap._digilap (pybind11): the C++ pipeline with NumPy arrays in and
// NumPy/SciPy out. The operator's CSR arrays and element arrays are handed to NumPy as views on
// the C++ operator's memory (each view keeps the operator alive), never copied. The GIL is
// released around every call that computes. The pure-Python layer (digilap/__init__.py) adds
// the one-call laplacian() and the docstrings' conventions.
#include "digilap/core/constants.hpp"
#include "digilap/digilap.hpp"
#include "digilap/surface/heat_laplacian.hpp"
#include "digilap/surface/matrix_free.hpp"
#include "digilap/surface/matrix_free_heat_flow.hpp"
#include "digilap/surface/ply.hpp"
#include "digilap/surface/smoothing.hpp"
#include "digilap/surface/volume.hpp"

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <limits>
#include <map>
#include <memory>
#include <string>

namespace py = pybind11;
using namespace digilap;

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

namespace {

using Release = py::call_guard<py::gil_scoped_release>;

// A x (stiffness) or L x on the matrix-free surface operator, x a vector or a block, the size
// checked with a ValueError and the GIL released for the product.
Eigen::MatrixXd surface_product(const surface::MatrixFreeSurfaceOperator& op, const Eigen::MatrixXd& x, bool stiffness) {
  if (x.rows() != op.rows())
    throw py::value_error("x: expected " + std::to_string(op.rows()) + " rows, got " + std::to_string(x.rows()));
  py::gil_scoped_release release;
  Eigen::MatrixXd y;
  if (stiffness) op.apply_stiffness(x, y);
  else op.apply_laplacian(x, y);
  return y;
}

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
py::object csr_view(const SparseMatrix& m, py::handle owner) {
  if (m.rows() == 0) return py::none();
  const auto n = static_cast<py::ssize_t>(m.rows()), nnz = static_cast<py::ssize_t>(m.nonZeros());
  py::array data = view(m.valuePtr(), {nnz}, owner), indices = view(m.innerIndexPtr(), {nnz}, owner),
            indptr = view(m.outerIndexPtr(), {n + 1}, owner);
  // digilap._views.OperatorMatrix: a csr_matrix whose in-place methods say to take a copy.
  py::object csr = py::module_::import("digilap._views").attr("OperatorMatrix");
  return csr(py::make_tuple(data, indices, indptr), py::arg("shape") = py::make_tuple(n, n), py::arg("copy") = false);
}

// A 3-D mask as voxels, in nibabel's convention: volume[i, j, k] is voxel (i, j, k), so that
// nib.load(f).get_fdata() == 3 gives the voxels of read_volume(f, label=3). Read in place
// through the array's strides (C or Fortran order, views) for bool and 8-bit masks; with a label,
// or wider integers, through a boolean copy (one byte a voxel).
surface::VoxelSet voxels_from_mask(const py::array& volume, double h, py::object label) {
  if (volume.ndim() != 3)
    throw py::value_error("from_mask: expected a 3-D array (i, j, k), got " + std::to_string(volume.ndim()) + " dimension(s)");
  const char kind = volume.dtype().kind();
  if (kind != 'b' && kind != 'u' && kind != 'i' && (label.is_none() || kind != 'f'))
    throw py::type_error("from_mask: expected a boolean or integer array (a float one with a label), got dtype " +
                         py::str(volume.dtype()).cast<std::string>());
  require_positive("from_mask: h", h);
  py::array bytes = volume;
  if (!label.is_none()) bytes = py::array(volume.attr("__eq__")(label));
  else if (volume.itemsize() != 1) bytes = py::array(volume.attr("astype")("bool"));
  const auto* base = static_cast<const std::uint8_t*>(bytes.data());
  const py::ssize_t nx = bytes.shape(0), ny = bytes.shape(1), nz = bytes.shape(2);
  const py::ssize_t si = bytes.strides(0), sj = bytes.strides(1), sk = bytes.strides(2);
  py::gil_scoped_release release;
  return surface::VoxelSet::from_mask(h, base, nx, ny, nz, si, sj, sk);
}

// A boolean mask (rows x columns, row 0 at the top: the frame of read_image) as a digital set:
// column c, row r is pixel (c, rows - 1 - r).
DigitalSet set_from_mask(const py::array& mask, double h) {
  if (mask.ndim() != 2)
    throw py::value_error("mask: expected a 2-D array (rows x columns), got " + std::to_string(mask.ndim()) + " dimension(s)");
  if (mask.dtype().kind() != 'b' && mask.dtype().kind() != 'u' && mask.dtype().kind() != 'i')
    throw py::type_error("mask: expected a boolean or integer array, got dtype " + py::str(mask.dtype()).cast<std::string>());
  if (!(h == 0 || (h > 0 && std::isfinite(h)))) require_positive("mask: h", h);
  // Read in place through the array's strides, byte by byte (a boolean or 8-bit mask is never
  // copied; wider integers are compared with 0 in a converted copy): runs row by row.
  const py::array bytes = mask.itemsize() == 1 ? mask : py::array(mask.attr("astype")("bool"));
  const py::ssize_t rows = bytes.shape(0), cols = bytes.shape(1);
  if (rows == 0 || cols == 0) throw py::value_error("mask: the array is empty (" + std::to_string(rows) + " x " + std::to_string(cols) + ")");
  if (rows > kMaxPixelIndex || cols > kMaxPixelIndex) throw py::value_error("mask: too large (" + std::to_string(rows) + " x " + std::to_string(cols) + ")");
  const auto* base = static_cast<const std::uint8_t*>(bytes.data());
  const py::ssize_t row_stride = bytes.strides(0), col_stride = bytes.strides(1);
  std::vector<std::vector<Run>> runs(static_cast<std::size_t>(rows));
  for (py::ssize_t r = 0; r < rows; ++r) {
    const std::uint8_t* row = base + r * row_stride;
    std::vector<Run>& out = runs[static_cast<std::size_t>(rows - 1 - r)];  // row 0 at the top: y = rows - 1
    for (py::ssize_t c = 0; c < cols;) {
      if (!row[c * col_stride]) { ++c; continue; }
      py::ssize_t e = c;
      while (e < cols && row[e * col_stride]) ++e;
      out.push_back({static_cast<std::int32_t>(c), static_cast<std::int32_t>(e)});
      c = e;
    }
  }
  return DigitalSet::from_rows(h > 0 ? h : 1.0 / static_cast<double>(std::max(rows, cols)), 0, std::move(runs));
}

// A Python callable as a function of a PolarCurve. The library calls it from OpenMP workers as
// well, with the GIL released: each call takes the GIL. An exception (or a non-number) must not
// cross the C++ code: it becomes NaN, which the curve's own check of its 2^15 samples at
// construction refuses, and its message is kept for that error.
struct PythonFunction {
  std::shared_ptr<py::function> f;
  std::shared_ptr<std::string> error;
  std::string name;
  double operator()(double theta) const {
    py::gil_scoped_acquire gil;
    try {
      return f->operator()(theta).cast<double>();
    } catch (const std::exception& e) {  // py::error_already_set, py::cast_error
      if (error->empty()) *error = name + "(" + std::to_string(theta) + ") failed: " + e.what();
      return std::numeric_limits<double>::quiet_NaN();
    }
  }
};
PythonFunction python_function(const py::function& f, const std::shared_ptr<std::string>& error, const char* name) {
  // The last reference to a Python object must be dropped with the GIL held, wherever the
  // curve happens to be destroyed.
  std::shared_ptr<py::function> held(new py::function(f), [](py::function* p) {
    py::gil_scoped_acquire gil;
    delete p;
  });
  return {held, error, name};
}

std::shared_ptr<PolarCurve> polar_curve(const py::function& r, const py::function& dr, const py::function& d2r,
                                        const std::string& name) {
  auto error = std::make_shared<std::string>();
  std::shared_ptr<PolarCurve> curve;
  try {
    curve = std::make_shared<PolarCurve>(python_function(r, error, "r"), python_function(dr, error, "dr"),
                                         python_function(d2r, error, "d2r"), name);
    // The construction samples r and r' only: try r'' too (the curvature uses it).
    for (int k = 0; k < 64; ++k) curve->curvature(-kPi + 2 * kPi * k / 64);
  } catch (const Error&) {
    if (error->empty()) throw;
  }
  if (!error->empty()) throw Error("PolarCurve: " + *error);
  return curve;
}

DistanceMode distance_of(const std::string& s) {
  if (s == "geodesic") return DistanceMode::Geodesic;
  if (s == "euclidean") return DistanceMode::Euclidean;
  throw py::value_error("distance: expected 'geodesic' or 'euclidean', got '" + s + "'");
}
Placement placement_of(const std::string& s) {
  if (s == "pointels") return Placement::Pointels;
  if (s == "linels") return Placement::Linels;
  throw py::value_error("placement: expected 'pointels' or 'linels', got '" + s + "'");
}

}  // namespace

PYBIND11_MODULE(_digilap, m) {
  m.doc() = "digilap: a convergent Laplace-Beltrami operator on the boundary of digitized shapes (C++ core).";
  static py::exception<Error> error(m, "Error", PyExc_ValueError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Error& e) {
      PyErr_SetString(error.ptr(), e.what());
    }
  });

  // --- Shapes ------------------------------------------------------------------------------
  py::class_<Shape, std::shared_ptr<Shape>>(m, "Shape", "A closed parametric curve theta -> point (SPEC §6).")
      .def_property_readonly("name", &Shape::name)
      .def("length", &Shape::length, "Exact length of the curve.")
      .def("point", &Shape::point, py::arg("theta"), "The point at parameter theta, as a 2-vector.")
      .def("inside", &Shape::inside, py::arg("p"), "Whether p is strictly inside the curve.")
      .def("closest_parameter", &Shape::closest_parameter, py::arg("p"),
           "The parameter of the point of the curve closest to p (orthogonal projection).")
      .def("set_pose", &Shape::set_pose, py::arg("centre"), py::arg("rotation"),
           "Moves the shape's centre to `centre` and rotates it by `rotation` radians.");
  py::class_<PolarCurve, Shape, std::shared_ptr<PolarCurve>>(
      m, "PolarCurve", "A polar curve r(theta) > 0 from Python callables r, dr = r', d2r = r'' (theta in [-pi, pi)).")
      .def(py::init(&polar_curve), py::arg("r"), py::arg("dr"), py::arg("d2r"), py::arg("name") = "polar");
  py::class_<Circle, PolarCurve, std::shared_ptr<Circle>>(m, "Circle", "Circle of radius r.")
      .def(py::init<double>(), py::arg("r") = 1.0);
  py::class_<Ellipse, Shape, std::shared_ptr<Ellipse>>(m, "Ellipse", "Ellipse with semi-axes a (x) and b (y).")
      .def(py::init<double, double>(), py::arg("a") = 2.0, py::arg("b") = 1.0);
  py::class_<Flower, PolarCurve, std::shared_ptr<Flower>>(m, "Flower", "Flower r = R + v cos(k theta + phi).")
      .def(py::init<double, double, int, double>(), py::arg("R") = 2.0, py::arg("v") = 0.5, py::arg("k") = 5, py::arg("phi") = 0.0);
  py::class_<AccFlower, PolarCurve, std::shared_ptr<AccFlower>>(m, "AccFlower", "Accelerated flower r = R + v cos(2k/pi^2 theta^3).")
      .def(py::init<double, double, int>(), py::arg("R") = 2.0, py::arg("v") = 0.25, py::arg("k") = 2);
  m.def("make_shape", [](const std::string& spec) { return std::shared_ptr<Shape>(make_shape(spec)); }, py::arg("spec"),
        "A reference shape from text: 'flower', 'flower:R=1.5,v=0.3,k=4', 'circle:r=2', ...");

  // --- Digital sets and contours -------------------------------------------------------------
  py::class_<DigitalSet>(m, "DigitalSet", "A set of pixels (i, j) of the grid hZ^2, stored as runs per row.")
      .def_property_readonly("h", &DigitalSet::h)
      .def("pixel_count", &DigitalSet::pixel_count)
      .def("contains", &DigitalSet::contains, py::arg("i"), py::arg("j"));
  m.def("digitize", &digitize, py::arg("shape"), py::arg("h"), Release(),
        "Gauss digitization: the pixels (i h, j h) strictly inside the shape.");
  m.def("from_mask", &set_from_mask, py::arg("mask"), py::arg("h") = 0.0,
        "A digital set from a 2-D boolean mask (True = foreground), row 0 at the top (the frame of "
        "read_image and of scikit-image): column c, row r is the pixel (c, rows - 1 - r). h = 0 means "
        "1 / max(rows, columns), the mask spanning the unit square.");
  m.def("read_image", [](const FilePath& path, double h, double threshold, bool invert) {
        const GrayImage image = read_image(path.value);
        return binarize(image, BinarizeOptions{h, threshold, invert});
      }, py::arg("path"), py::arg("h") = 0.0, py::arg("threshold") = 0.5, py::arg("invert") = false, Release(),
      "Reads a PBM, PGM or PNG file and keeps the pixels darker than threshold * maxval (lighter with invert).");
  py::class_<Contour>(m, "Contour", "A closed cycle of linels; pointels[i] (integers) starts linel i.")
      .def("__len__", &Contour::size)
      .def_property_readonly("pointels", [](const Contour& c) {
        Eigen::MatrixX2i p(static_cast<Eigen::Index>(c.size()), 2);
        for (std::size_t i = 0; i < c.size(); ++i) p.row(static_cast<Eigen::Index>(i)) = c.pointels[i].transpose();
        return p;
      })
      .def("twice_signed_area", &Contour::twice_signed_area)
      .def("is_hole", &Contour::is_hole);
  py::class_<ContourSet>(m, "ContourSet", "The contours of a digital set, with its grid step h.")
      .def_readonly("h", &ContourSet::h)
      .def_readonly("contours", &ContourSet::contours)
      .def("__len__", [](const ContourSet& c) { return c.contours.size(); })
      .def("linel_count", &ContourSet::linel_count);
  m.def("track_contours", &track_contours, py::arg("set"), Release(), "Every contour of a digital set (outer ones CCW, holes CW).");
  m.def("filter_contours", [](const ContourSet& c, std::size_t min_linels, bool largest_only) {
        return filter_contours(c, {min_linels, largest_only}).contours;
      }, py::arg("contours"), py::arg("min_linels") = 0, py::arg("largest_only") = false,
      "The contours with at least min_linels linels (or the largest only).");

  // --- Normals, measures ---------------------------------------------------------------------
  py::class_<LinelNormals>(m, "LinelNormals", "One unit normal per linel, with the length scale l and radius R used.")
      .def_readonly("length_scale", &LinelNormals::length_scale)
      .def_readonly("radius", &LinelNormals::radius)
      .def("__getitem__", [](const LinelNormals& n, std::size_t c) -> Eigen::MatrixX2d { return n.at(c); });
  m.def("ii_normals", [](const DigitalSet& s, const ContourSet& c, double k_R, double length_scale) {
        return ii_normals(s, c, {k_R, length_scale});
      }, py::arg("set"), py::arg("contours"), py::arg("k_R") = IINormalOptions{}.k_R, py::arg("length_scale") = 0.0,
      Release(), "Integral Invariant normals, disk radius R = k_R h^(1/3) l^(2/3) (l measured when 0).");
  m.def("exact_normals", &exact_normals, py::arg("shape"), py::arg("contours"), py::arg("length_scale") = 0.0, Release(),
        "The exact outward normals of a reference shape at the linels' closest points.");
  py::class_<Measures>(m, "Measures", "Lengths mu of linels and vertices, arclengths, and the length scale.")
      .def_readonly("length_scale", &Measures::length_scale)
      .def_readonly("normal_radius", &Measures::normal_radius)
      .def_readonly("clamped", &Measures::clamped, "Linels with <n, n_e> <= 0 (mu clamped to 0).")
      .def_property_readonly("clamped_linels", [](const Measures& m) { return m.clamped; }, "Deprecated: clamped.")
      .def("total_length", &Measures::total_length);
  m.def("measures", &measures, py::arg("contours"), py::arg("normals"), Release(),
        "mu(l) = h <n, n_e> (clamped at 0), mu(v) the mean of its two linels, arclength S.");
  m.def("length_scale", [](const DigitalSet& s, const ContourSet& c) { return length_scale(s, c).length; },
        py::arg("set"), py::arg("contours"), Release(), "The shape's length scale l (a robust small radius of curvature).");

  // --- The operator ---------------------------------------------------------------------------
  py::class_<HeatOperator, std::shared_ptr<HeatOperator>>(
      m, "HeatOperator",
      "What every operator is, curves (dimension 1) and surfaces (2): L (approximates +Laplace-Beltrami, negative "
      "semidefinite), A = M L (symmetric), M = diag(mu), all scipy.sparse.csr_matrix views on the operator's memory; "
      "rows grouped in parts (contours, surfaces) by row_offset. Zero-mass rows are off the support of mu: spectra and "
      "heat flow give them the average of their neighbours (their row of L).")
      .def_property_readonly("L", [](py::object self) { return csr_view(self.cast<HeatOperator&>().L, self); })
      .def_property_readonly("A", [](py::object self) { return csr_view(self.cast<HeatOperator&>().A, self); })
      .def_property_readonly("M", [](py::object self) { return csr_view(self.cast<HeatOperator&>().M, self); })
      .def_property_readonly("mass", [](py::object self) {
        const auto& op = self.cast<HeatOperator&>();
        return view(op.mass.data(), {op.mass.size()}, self);
      })
      .def_readonly("dimension", &HeatOperator::dimension)
      .def_readonly("t", &HeatOperator::t)
      .def_readonly("part_t", &HeatOperator::part_t)
      .def_readonly("cut", &HeatOperator::cut)
      .def_readonly("length_scale", &HeatOperator::length_scale)
      .def_property_readonly("row_offset", [](const HeatOperator& op) { return op.row_offset; })
      .def("massless_rows", &HeatOperator::massless_rows, "Rows of zero mass (off the support of mu).")
      .def("rows", &HeatOperator::rows);
  py::class_<ContourOperator, HeatOperator, std::shared_ptr<ContourOperator>>(
      m, "ContourOperator",
      "The operator on the elements of contours (a HeatOperator of dimension 1; parts = contours), with positions, "
      "arclength and contour lengths.")
      .def_property_readonly("arclength", [](py::object self) {
        const auto& op = self.cast<ContourOperator&>();
        return view(op.arclength.data(), {op.arclength.size()}, self);
      })
      .def_property_readonly("positions", [](py::object self) {
        const auto& op = self.cast<ContourOperator&>();  // column-major N x 2: x then y
        py::array a = view(op.positions.data(), {2, op.positions.rows()}, self);
        return py::object(a.attr("T"));
      })
      .def_readonly("contour_length", &ContourOperator::contour_length)
      .def_readonly("contour_t", &ContourOperator::part_t, "The heat time of each contour (part_t).");
  m.def("heat_laplacian", [](const ContourSet& c, const Measures& mu, double t, double c_t, double k, const std::string& d,
                             const std::string& p, bool richardson, bool stiffness, double length_scale, double memory_limit,
                             bool per_contour_time) {
        HeatLaplacianOptions o;
        o.t = t, o.c_t = c_t, o.k = k, o.distance = distance_of(d), o.placement = placement_of(p), o.richardson = richardson;
        o.stiffness = stiffness, o.length_scale = length_scale, o.memory_limit_bytes = memory_limit;
        o.per_contour_time = per_contour_time;
        return std::shared_ptr<ContourOperator>(new ContourOperator(heat_laplacian(c, mu, o)));  // elided: no copy of L, A
      }, py::arg("contours"), py::arg("mu"), py::arg("t") = 0.0, py::arg("c_t") = HeatLaplacianOptions{}.c_t,
      py::arg("k") = HeatLaplacianOptions{}.k, py::arg("distance") = "geodesic", py::arg("placement") = "pointels",
      py::arg("richardson") = false, py::arg("stiffness") = true, py::arg("length_scale") = 0.0,
      py::arg("memory_limit") = HeatLaplacianOptions{}.memory_limit_bytes,
      py::arg("per_contour_time") = HeatLaplacianOptions{}.per_contour_time, Release(),
      "The heat-kernel Laplacian of SPEC §4: (L g)_i = 1/(t sqrt(4 pi t)) sum_j exp(-d_ij^2/(4t)) (g_j - g_i) mu_j over\n"
      "d_ij <= k sqrt(t). t = 0 means c_t h^(2/3) l^(4/3) (l: the measures' length scale, or length_scale),\n"
      "in geodesic mode each contour's own l_c unless per_contour_time=False (op.contour_t).\n"
      "distance: 'geodesic' (along the contour) or 'euclidean'; placement: 'pointels' or 'linels'.\n"
      "Returns a ContourOperator: L (+Laplace-Beltrami, negative semidefinite), A = M L (symmetric), M.");
  m.def("dec_laplacian", [](const ContourSet& c, const Measures& mu, bool corrected) {
        return std::shared_ptr<ContourOperator>(new ContourOperator(dec_laplacian(c, mu, corrected ? DecLengths::Corrected : DecLengths::Naive)));
      }, py::arg("contours"), py::arg("mu"), py::arg("corrected") = true, Release(),
      "The DEC baseline (does not converge on digital curves; the paper's point), lengths mu (corrected) or h.");

  // --- Spectra, heat, files --------------------------------------------------------------------
  py::class_<Spectrum>(m, "Spectrum", "Eigenpairs of -A x = lambda M x, ascending, M-orthonormal vectors.")
      .def_readonly("eigenvalues", &Spectrum::eigenvalues)
      .def_readonly("laplace_beltrami", &Spectrum::laplace_beltrami)
      .def_readonly("eigenvectors", &Spectrum::eigenvectors)
      .def_readonly("iterations", &Spectrum::iterations)
      .def_readonly("massless", &Spectrum::massless, "Rows of zero mass (off the support of mu).")
      .def_readonly("undefined_estimates", &Spectrum::undefined_estimates);
  m.def("smallest_eigenpairs", [](const HeatOperator& op, int count) { return smallest_eigenpairs(op, {count}); },
        py::arg("op"), py::arg("count") = 10, Release(),
        "The count smallest eigenpairs of (-A, M) on the support of mu (every copy of repeated ones), with the\n"
        "Laplace-Beltrami estimates; curves and surfaces alike.");
  m.def("heat_kernel_signature", &heat_kernel_signature, py::arg("spectrum"), py::arg("times"), Release(),
        "HKS(x, tau) = sum_k exp(-lambda_k tau) phi_k(x)^2 of every row at each time: N x len(times).");
  m.def("heat_kernel_signature_times", &heat_kernel_signature_times, py::arg("spectrum"), py::arg("count") = 5,
        "Times log-spaced from 4 ln 10 / lambda_last to 4 ln 10 / lambda_1.");
  m.def("smallest_eigenpairs_per_part", [](const HeatOperator& op, int count) { return smallest_eigenpairs_per_part(op, {count}); },
        py::arg("op"), py::arg("count") = 10, Release(), "The spectrum of each part (contour, surface) on its own.");
  m.def("smallest_eigenpairs_per_contour", [](const HeatOperator& op, int count) { return smallest_eigenpairs_per_part(op, {count}); },
        py::arg("op"), py::arg("count") = 10, Release(), "The spectrum of each contour on its own (smallest_eigenpairs_per_part).");
  py::class_<MatrixFreeLaplacian, std::shared_ptr<MatrixFreeLaplacian>>(
      m, "MatrixFreeLaplacian", "L applied without storing it (geodesic mode, 1D fast Gauss transform to epsilon).")
      .def(py::init([](const ContourSet& c, const Measures& mu, double t, double c_t, double k, double epsilon) {
             HeatLaplacianOptions o;
             o.t = t, o.c_t = c_t, o.k = k;
             py::gil_scoped_release release;
             return std::make_shared<MatrixFreeLaplacian>(c, mu, o, epsilon);
           }), py::arg("contours"), py::arg("mu"), py::arg("t") = 0.0, py::arg("c_t") = HeatLaplacianOptions{}.c_t,
           py::arg("k") = HeatLaplacianOptions{}.k, py::arg("epsilon") = 1e-10)
      .def("rows", &MatrixFreeLaplacian::rows)
      .def_property_readonly("t", &MatrixFreeLaplacian::t)
      .def_property_readonly("contour_t", &MatrixFreeLaplacian::contour_t)
      .def_property_readonly("mass", &MatrixFreeLaplacian::mass)
      .def("matvec", [](const MatrixFreeLaplacian& op, const Eigen::VectorXd& x) {
        if (x.size() != op.rows())
          throw py::value_error("x: expected " + std::to_string(op.rows()) + " values, got " + std::to_string(x.size()));
        py::gil_scoped_release release;
        return Eigen::VectorXd(op * x);
      }, py::arg("x"), "L x.")
      .def("smallest_eigenpairs", [](const MatrixFreeLaplacian& op, int count) { return smallest_eigenpairs(op, {count}); },
           py::arg("count") = 10, Release(), "The count smallest eigenpairs (preconditioned LOBPCG per contour).");
  py::enum_<TimeScheme>(m, "TimeScheme").value("implicit_euler", TimeScheme::ImplicitEuler).value("crank_nicolson", TimeScheme::CrankNicolson);
  py::enum_<HeatSolver>(m, "HeatSolver")
      .value("auto", HeatSolver::Auto)
      .value("factorization", HeatSolver::Factorization)
      .value("conjugate_gradient", HeatSolver::ConjugateGradient);
  py::class_<HeatFlow>(m, "HeatFlow", "Heat diffusion du/dtau = L u on any operator (curves: factorized once; surfaces: conjugate\n"
                                      "gradients per step, where the factors would fill in); conserves each part's heat.")
      .def(py::init([](const HeatOperator& op, double dt, TimeScheme s, HeatSolver solver) {
             py::gil_scoped_release release;
             return std::make_unique<HeatFlow>(op, dt, s, solver);
           }), py::arg("op"), py::arg("dt"), py::arg("scheme") = TimeScheme::CrankNicolson, py::arg("solver") = HeatSolver::Auto)
      .def_property_readonly("solver", &HeatFlow::solver, "The solver in use (auto resolved).")
      .def_property_readonly("last_iterations", &HeatFlow::last_iterations, "CG iterations of the last step (0 factorized).")
      .def("step", &HeatFlow::step, py::arg("u"), Release())
      .def("advance", &HeatFlow::advance, py::arg("u0"), py::arg("steps"), Release());
  m.def("smooth_function", py::overload_cast<const HeatOperator&, const Eigen::VectorXd&, double, int>(&smooth_function), py::arg("op"), py::arg("f"), py::arg("tau"), py::arg("steps") = 1, Release(),
        "f after heat diffusion for a time tau (implicit Euler steps).");
  m.def("smooth_positions", [](const ContourOperator& op, double tau, int steps, bool preserve_size, py::object preserve_area) {
        ContourSmoothingOptions o;
        o.tau = tau, o.steps = steps, o.preserve_size = preserve_size;
        if (!preserve_area.is_none()) {  // the earlier keyword, as in C++ (CHANGELOG)
          if (PyErr_WarnEx(PyExc_DeprecationWarning, "smooth_positions: preserve_area is renamed preserve_size", 1) != 0)
            throw py::error_already_set();
          o.preserve_size = o.preserve_size && preserve_area.cast<bool>();
        }
        py::gil_scoped_release release;
        return smooth_positions(op, o);
      }, py::arg("op"), py::arg("tau") = ContourSmoothingOptions{}.tau, py::arg("steps") = ContourSmoothingOptions{}.steps,
      py::arg("preserve_size") = ContourSmoothingOptions{}.preserve_size, py::arg("preserve_area") = py::none(),
      "Contour fairing: the element positions after heat diffusion (N x 2), rescaled to their enclosed area unless preserve_size=False.");
  m.def("convergence_sweep", [](const Shape& shape, const std::string& function, std::vector<double> steps,
                                std::vector<std::string> operators) {
        ConvergenceOptions o;
        o.steps = std::move(steps);
        for (const auto& name : operators) o.variants.push_back(operator_variant(name));
        const TestFunction f = make_test_function(function);
        ConvergenceResult r;
        {
          py::gil_scoped_release release;
          r = convergence_sweep(shape, f, o);
        }
        py::list rows;
        for (const ConvergenceRow& row : r.rows) {
          py::dict d;
          d["h"] = row.h, d["operator"] = row.variant, d["N"] = row.elements, d["nnz"] = row.nonzeros, d["t"] = row.t;
          d["length_scale"] = row.length_scale, d["max_error"] = row.max_error, d["mean_error"] = row.mean_error;
          d["relative_max_error"] = row.relative_max_error, d["length_estimate"] = row.length_estimate;
          d["length_exact"] = row.length_exact;
          rows.append(d);
        }
        return rows;
      }, py::arg("shape"), py::arg("function") = "x2",
      py::arg("steps") = std::vector<double>{0.1, 0.05, 0.02, 0.01, 0.005, 0.002, 0.001},
      py::arg("operators") = std::vector<std::string>{"geodesic"},
      "The convergence experiment (the paper's Fig. 5): one dict per (h, operator) with the errors against the exact\n"
      "Laplace-Beltrami operator of the test function ('x2', 'xy', 'cos1' .. 'cos9').");
  m.def("save_operator", [](const ContourOperator& op, const FilePath& directory, const std::string& prefix, const std::string& format) {
        const std::string& dir = directory.value;
        if (format != "mtx" && format != "npz") throw py::value_error("format: expected 'mtx' or 'npz', got '" + format + "'");
        py::gil_scoped_release release;
        const FileFormat f = format == "npz" ? FileFormat::Npz : FileFormat::MatrixMarket;
        return save_operator(op, dir, prefix, f);
      }, py::arg("op"), py::arg("directory"), py::arg("prefix") = "", py::arg("format") = "mtx",
      "Writes L, A, M and the element table (Matrix Market + CSV, or .npz).");
  m.def("save_operator", [](const HeatOperator& op, const FilePath& directory, const std::string& prefix, const std::string& format) {
        const std::string& dir = directory.value;
        if (format != "mtx" && format != "npz") throw py::value_error("format: expected 'mtx' or 'npz', got '" + format + "'");
        py::gil_scoped_release release;
        const FileFormat f = format == "npz" ? FileFormat::Npz : FileFormat::MatrixMarket;
        return save_operator(op, dir, prefix, f);
      }, py::arg("op"), py::arg("directory"), py::arg("prefix") = "", py::arg("format") = "mtx",
      "Writes L, A and M of any operator (Matrix Market, or .npz).");
  // --- Surfaces (SPEC §7): the submodule digilap.surface --------------------------------------
  py::module_ s = m.def_submodule("surface", "Digital surfaces in 3D: the same operator on the surfels of a voxel set.");
  py::class_<surface::Surface, std::shared_ptr<surface::Surface>>(s, "Surface", "A closed surface with exact geometry.")
      .def_property_readonly("name", &surface::Surface::name)
      .def("area", &surface::Surface::area, "Exact area.")
      .def("inside", &surface::Surface::inside, py::arg("p"))
      .def("closest_point", &surface::Surface::closest_point, py::arg("p"), "The orthogonal projection of p on the surface.")
      .def("normal", &surface::Surface::normal, py::arg("on_surface"), "Outward unit normal at a point of the surface.")
      .def("mean_curvature", &surface::Surface::mean_curvature, py::arg("on_surface"), "H = (k1 + k2) / 2 (1 / r on a sphere).")
      .def("set_pose", &surface::Surface::set_pose, py::arg("centre"), py::arg("rotation"), "x -> rotation x + centre.");
  py::class_<surface::Sphere, surface::Surface, std::shared_ptr<surface::Sphere>>(s, "Sphere").def(py::init<double>(), py::arg("r") = 1.0);
  py::class_<surface::Ellipsoid, surface::Surface, std::shared_ptr<surface::Ellipsoid>>(s, "Ellipsoid")
      .def(py::init<double, double, double>(), py::arg("a") = 1.2, py::arg("b") = 1.0, py::arg("c") = 0.8);
  py::class_<surface::Torus, surface::Surface, std::shared_ptr<surface::Torus>>(s, "Torus")
      .def(py::init<double, double>(), py::arg("R") = 1.0, py::arg("r") = 0.4);
  py::class_<surface::VoxelSet>(s, "VoxelSet", "Voxels (i, j, k) of hZ^3 stored as runs along x.")
      .def_property_readonly("h", &surface::VoxelSet::h)
      .def("voxel_count", &surface::VoxelSet::voxel_count)
      .def("contains", &surface::VoxelSet::contains, py::arg("i"), py::arg("j"), py::arg("k"));
  s.def("digitize", &surface::digitize, py::arg("surface"), py::arg("h"), Release(), "Gauss digitization of a surface.");
  s.def(
      "read_volume",
      [](const FilePath& file, double h, std::int64_t label, double threshold, std::int64_t max_voxels) {
        const std::string& path = file.value;
        surface::VolumeOptions o;
        o.h = h, o.label = label, o.threshold = threshold, o.max_voxels = max_voxels;
        return surface::read_volume(path, o);
      },
      py::arg("path"), py::arg("h") = 0.0, py::arg("label") = -1, py::arg("threshold") = 1.0,
      py::arg("max_voxels") = surface::VolumeOptions{}.max_voxels, Release(),
      "Voxels of a .npy or NIfTI (.nii, .nii.gz) volume: value == label when label >= 0, else value >= "
      "threshold. h = 0: the NIfTI spacing, or 1 / (largest dimension) for .npy. Anisotropic spacing is refused.");
  s.def("from_mask", &voxels_from_mask, py::arg("volume"), py::arg("h") = 1.0, py::arg("label") = py::none(),
        "Voxels of a 3-D NumPy array: volume[i, j, k] is voxel (i, j, k) (nibabel's convention: get_fdata() == 3 gives\n"
        "read_volume(f, label=3)); foreground: volume == label when given, else volume != 0. h: the voxel size (1: voxel\n"
        "units; 1 mm voxels: eigenvalues in mm^-2). Bool and 8-bit arrays are read in place, any order or strides.");
  py::class_<surface::SurfelSet>(s, "SurfelSet", "The surfels of a voxel set: faces between a voxel inside and one outside,\n"
                                                  "grouped by connected surface (surface_offset).")
      .def("__len__", &surface::SurfelSet::size)
      .def_readonly("surface_offset", &surface::SurfelSet::surface_offset)
      .def("surfaces", &surface::SurfelSet::surfaces)
      .def_property_readonly("centres", &surface::SurfelSet::centres);
  s.def("extract_surfels", &surface::extract_surfels, py::arg("voxels"), Release());
  s.def("filter_surfels", [](const surface::VoxelSet& v, const surface::SurfelSet& f, std::size_t min_surfels, bool largest_only) {
        return surface::filter_surfels(v, f, {min_surfels, largest_only}).surfels;
      }, py::arg("voxels"), py::arg("surfels"), py::arg("min_surfels") = 0, py::arg("largest_only") = false, Release(),
      "The surfels of the surfaces kept: those with at least min_surfels, or the largest only.");
  s.def("enclosed_volume", [](const surface::SurfelSet& f) { return surface::enclosed_volume(f); }, py::arg("surfels"),
        "The volume the surfels enclose, exact on the voxels (h^3 units).");
  s.def("read_labels", [](const FilePath& file, double h) {
        const std::string& path = file.value;
        surface::VolumeOptions o;
        o.h = h;
        std::vector<surface::LabelVoxels> labels;
        {
          py::gil_scoped_release release;
          labels = surface::read_labels(path, o);
        }
        py::dict out;
        for (auto& l : labels) out[py::int_(l.label)] = std::move(l.voxels);
        return out;
      }, py::arg("path"), py::arg("h") = 0.0,
      "Every structure of a segmentation (.nii, .nii.gz, .npy) at once: {label: VoxelSet} for each non-zero label.");
  py::class_<surface::SurfelNormals>(s, "SurfelNormals")
      .def_readonly("normals", &surface::SurfelNormals::normals)
      .def_readonly("length_scale", &surface::SurfelNormals::length_scale)
      .def_readonly("radius", &surface::SurfelNormals::radius);
  s.def("ii_normals", [](const surface::VoxelSet& v, const surface::SurfelSet& f, double k_R, double l) {
        return surface::ii_normals(v, f, {k_R, l});
      }, py::arg("voxels"), py::arg("surfels"), py::arg("k_R") = surface::SurfaceNormalOptions{}.k_R, py::arg("length_scale") = 0.0,
      Release(), "II normals, ball radius R = k_R h^(1/3) l^(2/3) (l measured when 0).");
  py::class_<surface::SurfelMeasures>(s, "SurfelMeasures")
      .def_readonly("mu", &surface::SurfelMeasures::mu)
      .def_readonly("length_scale", &surface::SurfelMeasures::length_scale)
      .def_readonly("normal_radius", &surface::SurfelMeasures::normal_radius)
      .def_readonly("clamped", &surface::SurfelMeasures::clamped, "Surfels of zero area (II normal orthogonal to them).")
      .def_readonly("surface_length_scales", &surface::SurfelMeasures::surface_length_scales)
      .def("total_area", &surface::SurfelMeasures::total_area);
  s.def("measures", &surface::measures, py::arg("surfels"), py::arg("normals"), Release(), "Surfel areas mu = h^2 max(0, <n, n_e>).");
  py::class_<surface::SurfaceOperator, HeatOperator, std::shared_ptr<surface::SurfaceOperator>>(
      s, "SurfaceOperator", "The operator on surfels (a HeatOperator of dimension 2): L, A = M L, M as scipy.sparse.csr_matrix "
      "views; positions N x 3.")
      .def_readonly("positions", &surface::SurfaceOperator::positions);
  s.def("heat_laplacian", [](const surface::SurfelSet& f, const surface::SurfelMeasures& mu, double t, double c_t, double k,
                             double length_scale, double memory_limit, bool stiffness, bool per_surface_time, bool couple_surfaces) {
        HeatLaplacianOptions o;
        o.t = t, o.c_t = c_t, o.k = k, o.length_scale = length_scale, o.memory_limit_bytes = memory_limit;
        o.stiffness = stiffness, o.per_contour_time = per_surface_time, o.couple_surfaces = couple_surfaces;
        return std::shared_ptr<surface::SurfaceOperator>(new surface::SurfaceOperator(surface::heat_laplacian(f, mu, o)));
      }, py::arg("surfels"), py::arg("mu"), py::arg("t") = 0.0, py::arg("c_t") = HeatLaplacianOptions{}.c_t,
      py::arg("k") = HeatLaplacianOptions{}.k, py::arg("length_scale") = 0.0,
      py::arg("memory_limit") = HeatLaplacianOptions{}.memory_limit_bytes, py::arg("stiffness") = true,
      py::arg("per_surface_time") = true, py::arg("couple_surfaces") = false, Release(),
      "The heat-kernel Laplacian on surfels (SPEC §7): 1/(4 pi t^2) sum exp(-|x_i - x_j|^2/(4t)) (g_j - g_i) mu_j,\n"
      "only between surfels of the same connected surface (couple_surfaces=True: between any), each surface with its\n"
      "own heat time (per_surface_time=False: one for all).");
  s.def("smallest_eigenpairs_per_part", [](const HeatOperator& op, int count) { return smallest_eigenpairs_per_part(op, {count}); },
        py::arg("op"), py::arg("count") = 10, Release(), "The spectrum of each connected surface on its own.");
  s.def("smallest_eigenpairs", [](const HeatOperator& op, int count) { return smallest_eigenpairs(op, {count}); },
        py::arg("op"), py::arg("count") = 10, Release(),
        "The count smallest eigenpairs of (-A, M) on the support of mu, with Laplace-Beltrami estimates (digilap.smallest_eigenpairs).");
  // The operator without its matrices (issue 23): products, spectrum, heat flow and smoothing in
  // O(N) memory; digilap.surface adds as_linear_operator() for SciPy.
  py::class_<surface::MatrixFreeSurfaceOperator, std::shared_ptr<surface::MatrixFreeSurfaceOperator>>(
      s, "MatrixFreeSurfaceOperator",
      "The surface operator heat_laplacian() would assemble, applied without storing L or A: memory O(N).")
      .def(py::init([](const surface::SurfelSet& f, const surface::SurfelMeasures& mu, double t, double c_t, double k,
                       double length_scale, bool per_surface_time, bool couple_surfaces) {
             HeatLaplacianOptions o;
             o.t = t, o.c_t = c_t, o.k = k, o.length_scale = length_scale;
             o.per_contour_time = per_surface_time, o.couple_surfaces = couple_surfaces;
             py::gil_scoped_release release;
             return std::make_shared<surface::MatrixFreeSurfaceOperator>(f, mu, o);
           }), py::arg("surfels"), py::arg("mu"), py::arg("t") = 0.0, py::arg("c_t") = HeatLaplacianOptions{}.c_t,
           py::arg("k") = HeatLaplacianOptions{}.k, py::arg("length_scale") = 0.0, py::arg("per_surface_time") = true,
           py::arg("couple_surfaces") = false)
      .def("rows", &surface::MatrixFreeSurfaceOperator::rows)
      .def_property_readonly("t", &surface::MatrixFreeSurfaceOperator::t)
      .def_property_readonly("cut", &surface::MatrixFreeSurfaceOperator::cut)
      .def_property_readonly("mass", &surface::MatrixFreeSurfaceOperator::mass)
      .def_property_readonly("positions", &surface::MatrixFreeSurfaceOperator::positions)
      .def_property_readonly("row_offset", &surface::MatrixFreeSurfaceOperator::row_offset)
      .def_property_readonly("part_t", &surface::MatrixFreeSurfaceOperator::part_t)
      .def("bytes", &surface::MatrixFreeSurfaceOperator::bytes, "Bytes the operator holds (O(N)).")
      .def("matvec", [](const surface::MatrixFreeSurfaceOperator& op, const Eigen::MatrixXd& x) { return surface_product(op, x, false); },
           py::arg("x"), "L x for a vector or an N x b block (one neighbour search for the whole block).")
      .def("stiffness_matvec", [](const surface::MatrixFreeSurfaceOperator& op, const Eigen::MatrixXd& x) { return surface_product(op, x, true); },
           py::arg("x"), "A x = M L x (symmetric) for a vector or an N x b block.")
      .def("smallest_eigenpairs", [](const surface::MatrixFreeSurfaceOperator& op, int count) {
        return surface::smallest_eigenpairs(op, {count});
      }, py::arg("count") = 10, Release(), "The count smallest eigenpairs (LOBPCG preconditioned by the surfel graph Laplacian).");
  py::class_<surface::MatrixFreeHeatFlow>(s, "MatrixFreeHeatFlow",
                                          "Heat flow on a MatrixFreeSurfaceOperator, each step by conjugate gradients on products.")
      .def(py::init([](const surface::MatrixFreeSurfaceOperator& op, double dt, TimeScheme scheme) {
             py::gil_scoped_release release;
             return std::make_unique<surface::MatrixFreeHeatFlow>(op, dt, scheme);
           }), py::arg("op"), py::arg("dt"), py::arg("scheme") = TimeScheme::CrankNicolson,
           py::keep_alive<1, 2>())  // the flow keeps a reference to the operator
      .def("step", &surface::MatrixFreeHeatFlow::step, py::arg("u"), Release())
      .def("advance", &surface::MatrixFreeHeatFlow::advance, py::arg("u0"), py::arg("steps"), Release())
      .def_property_readonly("last_iterations", &surface::MatrixFreeHeatFlow::last_iterations);
  s.def("smooth", [](const surface::MatrixFreeSurfaceOperator& op, const Eigen::MatrixXd& f, double tau, int steps) {
        return surface::smooth(op, f, tau, steps);
      }, py::arg("op"), py::arg("f"), py::arg("tau"), py::arg("steps") = 1, Release(),
      "Columns of f diffused for time tau (implicit Euler) on the matrix-free operator.");
  s.def("smooth_positions", [](const surface::SurfaceOperator& op, double tau, int steps, bool preserve_size) {
        return surface::smooth_positions(op, {tau, steps, preserve_size});
      }, py::arg("op"), py::arg("tau") = surface::SurfaceSmoothingOptions{}.tau,
      py::arg("steps") = surface::SurfaceSmoothingOptions{}.steps,
      py::arg("preserve_size") = surface::SurfaceSmoothingOptions{}.preserve_size, Release(),
      "Fairing: the surfel centres diffused for time tau (N x 3), rescaled to their RMS size unless preserve_size=False.");
  s.def("save_ply", [](const surface::SurfelSet& f, const std::map<std::string, Eigen::VectorXd>& fields, const FilePath& path) {
        const std::vector<std::pair<std::string, Eigen::VectorXd>> list(fields.begin(), fields.end());
        const auto size = surface::save_ply(f, list, path.value);
        return py::make_tuple(size.vertices, size.faces);
      }, py::arg("surfels"), py::arg("fields"), py::arg("path"), "Writes the surfels as a PLY quad mesh with per-surfel fields.");

  m.def("load_matrix_market", [](const FilePath& path) { return load_matrix_market(path.value); }, py::arg("path"), Release(),
        "Reads a Matrix Market coordinate file (general or symmetric) as a scipy-compatible sparse matrix.");
}
