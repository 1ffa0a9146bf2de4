// The curves' bindings (digilap.*): shapes, digital sets from masks, contours, normals, measures,
// the contour operator and its matrix-free form, contour smoothing, convergence sweeps, files.
#include "common.hpp"

#include "digilap/core/constants.hpp"
#include "digilap/digilap.hpp"

#include <limits>
#include <memory>
#include <string>

namespace digilap::python {

namespace {

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

void bind_curve(py::module_& m) {
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

  m.def("smallest_eigenpairs_per_contour", [](const HeatOperator& op, int count, double tolerance, int max_iterations) {
          return smallest_eigenpairs_per_part(op, spectrum_options(count, tolerance, max_iterations));
        },
        py::arg("op"), py::arg("count") = 10, tolerance_argument(), max_iterations_argument(), Release(), "The spectrum of each contour on its own (smallest_eigenpairs_per_part).");
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
      .def("smallest_eigenpairs", [](const MatrixFreeLaplacian& op, int count, double tolerance, int max_iterations) {
             return smallest_eigenpairs(op, spectrum_options(count, tolerance, max_iterations));
           },
           py::arg("count") = 10, tolerance_argument(), max_iterations_argument(), Release(), "The count smallest eigenpairs (preconditioned LOBPCG per contour).");
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
        const FileFormat f = file_format_of(format);
        py::gil_scoped_release release;
        return save_operator(op, directory.value, prefix, f);
      }, py::arg("op"), py::arg("directory"), py::arg("prefix") = "", py::arg("format") = "mtx", py::prepend(),
      "Writes L, A, M and the element table (Matrix Market + CSV, or .npz).");
}

}  // namespace digilap::python
