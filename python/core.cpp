// The core's bindings (every dimension): digilap.Error, HeatOperator with its zero-copy views,
// spectra, heat kernel signatures, heat flow, function smoothing, matrix files.
#include "common.hpp"

#include "digilap/core/bias_correction.hpp"
#include "digilap/core/error.hpp"
#include "digilap/core/heat_flow.hpp"
#include "digilap/core/io.hpp"
#include "digilap/core/smoothing.hpp"
#include "digilap/core/spectrum.hpp"

namespace digilap::python {

void bind_core(py::module_& m) {
  static py::exception<Error> error(m, "Error", PyExc_ValueError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Error& e) {
      PyErr_SetString(error.ptr(), e.what());
    }
  });

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
  // --- Spectra, heat, files --------------------------------------------------------------------
  py::class_<Spectrum>(m, "Spectrum", "Eigenpairs of -A x = lambda M x, ascending, M-orthonormal vectors.")
      .def_readonly("eigenvalues", &Spectrum::eigenvalues)
      .def_readonly("laplace_beltrami", &Spectrum::laplace_beltrami)
      .def_readonly("eigenvectors", &Spectrum::eigenvectors)
      .def_readonly("iterations", &Spectrum::iterations)
      .def_readonly("massless", &Spectrum::massless, "Rows of zero mass (off the support of mu).")
      .def_readonly("undefined_estimates", &Spectrum::undefined_estimates);
  m.attr("EIGENVALUES_ONLY_TOLERANCE") = kEigenvaluesOnlyTolerance;  // digilap/core/spectrum.hpp
  m.def("smallest_eigenpairs", [](const HeatOperator& op, int count, double tolerance, int max_iterations) {
          return smallest_eigenpairs(op, spectrum_options(count, tolerance, max_iterations));
        },
        py::arg("op"), py::arg("count") = 10, tolerance_argument(), max_iterations_argument(), Release(),
        "The count smallest eigenpairs of (-A, M) on the support of mu (every copy of repeated ones), with the\n"
        "Laplace-Beltrami estimates; curves and surfaces alike.");
  m.def("heat_kernel_signature", &heat_kernel_signature, py::arg("spectrum"), py::arg("times"), Release(),
        "HKS(x, tau) = sum_k exp(-lambda_k tau) phi_k(x)^2 of every row at each time: N x len(times).");
  m.def("heat_kernel_signature_times", &heat_kernel_signature_times, py::arg("spectrum"), py::arg("count") = 5,
        "Times log-spaced from 4 ln 10 / lambda_last to 4 ln 10 / lambda_1.");
  m.def("smallest_eigenpairs_per_part", [](const HeatOperator& op, int count, double tolerance, int max_iterations) {
          return smallest_eigenpairs_per_part(op, spectrum_options(count, tolerance, max_iterations));
        },
        py::arg("op"), py::arg("count") = 10, tolerance_argument(), max_iterations_argument(), Release(), "The spectrum of each part (contour, surface) on its own.");
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
  m.def("bias_corrected_laplacian", [](const HeatOperator& op, const Eigen::MatrixXd& g) {
        if (g.rows() != op.rows())
          throw py::value_error("g: expected " + std::to_string(op.rows()) + " rows, got " + std::to_string(g.rows()));
        py::gil_scoped_release release;
        return bias_corrected_laplacian(op, g);
      }, py::arg("op"), py::arg("g"),
      "L_c g = L g - (t/2) L (I + t L) L g for a vector or an N x b block: a pointwise Laplace-Beltrami estimate with the "
      "heat kernel's O(t) bias (t/2) Delta^2 g removed, each part with its own t (three products of L).");
  m.def("save_operator", [](const HeatOperator& op, const FilePath& directory, const std::string& prefix, const std::string& format) {
        const FileFormat f = file_format_of(format);
        py::gil_scoped_release release;
        return save_operator(op, directory.value, prefix, f);
      }, py::arg("op"), py::arg("directory"), py::arg("prefix") = "", py::arg("format") = "mtx",
      "Writes L, A and M of any operator (Matrix Market, or .npz).");
  m.def("load_matrix_market", [](const FilePath& path) { return load_matrix_market(path.value); }, py::arg("path"), Release(),
        "Reads a Matrix Market coordinate file (general or symmetric) as a scipy-compatible sparse matrix.");
}

}  // namespace digilap::python
