// The surfaces' bindings (the submodule digilap.surface): reference surfaces, volumes and masks,
// surfels, normals, areas, the surface operator and its matrix-free form, heat flow, smoothing, PLY.
#include "common.hpp"

#include "digilap/core/error.hpp"
#include "digilap/core/spectrum.hpp"
#include "digilap/surface/heat_laplacian.hpp"
#include "digilap/surface/matrix_free.hpp"
#include "digilap/surface/matrix_free_heat_flow.hpp"
#include "digilap/surface/ply.hpp"
#include "digilap/surface/smoothing.hpp"
#include "digilap/surface/ground_truth.hpp"
#include "digilap/surface/volume.hpp"

#include <limits>
#include <map>
#include <memory>
#include <string>

namespace digilap::python {

namespace {

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


SurfaceKernel surface_kernel_named(const std::string& s) {
  if (s == "chord") return SurfaceKernel::Chord;
  if (s == "intrinsic") return SurfaceKernel::Intrinsic;
  throw py::value_error("kernel: expected 'chord' or 'intrinsic', got '" + s + "'");
}
const char* surface_kernel_name(SurfaceKernel k) { return k == SurfaceKernel::Chord ? "chord" : "intrinsic"; }

}  // namespace

void bind_surface(py::module_& m, py::module_& s) {
  // --- Surfaces (SPEC §7): the submodule digilap.surface --------------------------------------
  py::class_<surface::Surface, std::shared_ptr<surface::Surface>>(s, "Surface", "A closed surface with exact geometry.")
      .def_property_readonly("name", &surface::Surface::name)
      .def("area", &surface::Surface::area, "Exact area.")
      .def("inside", &surface::Surface::inside, py::arg("p"))
      .def("closest_point", &surface::Surface::closest_point, py::arg("p"), "The orthogonal projection of p on the surface.")
      .def("normal", &surface::Surface::normal, py::arg("on_surface"), "Outward unit normal at a point of the surface.")
      .def("mean_curvature", &surface::Surface::mean_curvature, py::arg("on_surface"), "H = (k1 + k2) / 2 (1 / r on a sphere).")
      .def("set_pose", &surface::Surface::set_pose, py::arg("centre"), py::arg("rotation"), "x -> rotation x + centre.");
  s.def("make_surface", [](const std::string& spec) { return std::shared_ptr<surface::Surface>(surface::make_surface(spec)); },
        py::arg("spec"), "A reference surface by name with its parameters ('sphere:r=2', 'torus:R=1,r=0.4').");
  s.def("surface_names", &surface::surface_names, "The names make_surface knows.");
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
  s.def("ii_normals", [](const surface::VoxelSet& v, const surface::SurfelSet& f, double k_R, double l, bool remove_ball_anisotropy) {
        surface::SurfaceNormalOptions o;
        o.k_R = k_R, o.length_scale = l, o.remove_ball_anisotropy = remove_ball_anisotropy;
        return surface::ii_normals(v, f, o);
      }, py::arg("voxels"), py::arg("surfels"), py::arg("k_R") = surface::SurfaceNormalOptions{}.k_R, py::arg("length_scale") = 0.0,
      py::arg("remove_ball_anisotropy") = surface::SurfaceNormalOptions{}.remove_ball_anisotropy, Release(),
      "II normals, ball radius R = k_R h^(1/3) l^(2/3) (l measured when 0; k_R = 0: from l / h in [1, 1.5]); "
      "remove_ball_anisotropy=False: SPEC's plain covariance estimator.");
  s.def("exact_normals", [](const surface::Surface& surface, const surface::SurfelSet& f, double l) {
        return surface::exact_normals(surface, f, l);
      }, py::arg("surface"), py::arg("surfels"), py::arg("length_scale") = 0.0, Release(),
      "The exact outward normals at the surfel centres' closest points (l measured as for ii_normals when 0).");
  py::class_<surface::SurfelMeasures>(s, "SurfelMeasures")
      .def_readonly("mu", &surface::SurfelMeasures::mu)
      .def_readonly("length_scale", &surface::SurfelMeasures::length_scale)
      .def_readonly("normal_radius", &surface::SurfelMeasures::normal_radius)
      .def_readonly("clamped", &surface::SurfelMeasures::clamped, "Surfels of zero area (II normal orthogonal to them).")
      .def_readonly("surface_length_scales", &surface::SurfelMeasures::surface_length_scales)
      .def("total_area", &surface::SurfelMeasures::total_area);
  s.def("sphere_spectrum", &surface::sphere_spectrum, py::arg("radius"), py::arg("count"),
        "The count smallest Laplace-Beltrami eigenvalues of the sphere: l(l+1)/r^2, 2l+1 times each.");
  s.def("torus_spectrum", &surface::torus_spectrum, py::arg("R"), py::arg("r"), py::arg("count"),
        "The count smallest Laplace-Beltrami eigenvalues of the torus (R > r), by separation of variables (relative error < 1e-6).");
  s.def("measures", &surface::measures, py::arg("surfels"), py::arg("normals"), Release(), "Surfel areas mu = h^2 max(0, <n, n_e>).");
  py::class_<surface::SurfaceOperator, HeatOperator, std::shared_ptr<surface::SurfaceOperator>>(
      s, "SurfaceOperator", "The operator on surfels (a HeatOperator of dimension 2): L, A = M L, M as scipy.sparse.csr_matrix "
      "views; positions N x 3.")
      .def_readonly("positions", &surface::SurfaceOperator::positions);
  s.def("heat_laplacian", [](const surface::SurfelSet& f, const surface::SurfelMeasures& mu, double t, double c_t, double k,
                             double length_scale, double memory_limit, bool stiffness, bool per_surface_time, bool couple_surfaces,
                             const std::string& kernel) {
        HeatLaplacianOptions o;
        o.t = t, o.c_t = c_t, o.k = k, o.length_scale = length_scale, o.memory_limit_bytes = memory_limit;
        o.stiffness = stiffness, o.per_contour_time = per_surface_time, o.couple_surfaces = couple_surfaces;
        o.surface_kernel = surface_kernel_named(kernel);
        return std::shared_ptr<surface::SurfaceOperator>(new surface::SurfaceOperator(surface::heat_laplacian(f, mu, o)));
      }, py::arg("surfels"), py::arg("mu"), py::arg("t") = 0.0, py::arg("c_t") = HeatLaplacianOptions{}.c_t,
      py::arg("k") = HeatLaplacianOptions{}.k, py::arg("length_scale") = 0.0,
      py::arg("memory_limit") = HeatLaplacianOptions{}.memory_limit_bytes, py::arg("stiffness") = true,
      py::arg("per_surface_time") = true, py::arg("couple_surfaces") = false, py::arg("kernel") = surface_kernel_name(HeatLaplacianOptions{}.surface_kernel),
      Release(),
      "The heat-kernel Laplacian on surfels (SPEC §7): 1/(4 pi t^2) sum exp(-d_ij^2/(4t)) (g_j - g_i) mu_j,\n"
      "only between surfels of the same connected surface (couple_surfaces=True: between any), each surface with its\n"
      "own heat time (per_surface_time=False: one for all). kernel: 'chord' (d = |x_i - x_j|) or 'intrinsic' (the\n"
      "tangent-plane chord plus the geodesic term from the normals, weights corrected for the Gaussian curvature).");
  s.def("smallest_eigenpairs_per_part", [](const HeatOperator& op, int count, double tolerance, int max_iterations) {
          return smallest_eigenpairs_per_part(op, spectrum_options(count, tolerance, max_iterations));
        },
        py::arg("op"), py::arg("count") = 10, tolerance_argument(), max_iterations_argument(), Release(), "The spectrum of each connected surface on its own.");
  s.def("smallest_eigenpairs", [](const HeatOperator& op, int count, double tolerance, int max_iterations) {
          return smallest_eigenpairs(op, spectrum_options(count, tolerance, max_iterations));
        },
        py::arg("op"), py::arg("count") = 10, tolerance_argument(), max_iterations_argument(), Release(),
        "The count smallest eigenpairs of (-A, M) on the support of mu, with Laplace-Beltrami estimates (digilap.smallest_eigenpairs).");
  // The operator without its matrices (issue 23): products, spectrum, heat flow and smoothing in
  // O(N) memory; digilap.surface adds as_linear_operator() for SciPy.
  py::class_<surface::MatrixFreeSurfaceOperator, std::shared_ptr<surface::MatrixFreeSurfaceOperator>>(
      s, "MatrixFreeSurfaceOperator",
      "The surface operator heat_laplacian() would assemble, applied without storing L or A: memory O(N).")
      .def(py::init([](const surface::SurfelSet& f, const surface::SurfelMeasures& mu, double t, double c_t, double k,
                       double length_scale, bool per_surface_time, bool couple_surfaces, const std::string& kernel,
                       double stored_weights_bytes) {
             HeatLaplacianOptions o;
             o.t = t, o.c_t = c_t, o.k = k, o.length_scale = length_scale;
             o.per_contour_time = per_surface_time, o.couple_surfaces = couple_surfaces;
             o.surface_kernel = surface_kernel_named(kernel);
             o.stored_weights_bytes = stored_weights_bytes;
             py::gil_scoped_release release;
             return std::make_shared<surface::MatrixFreeSurfaceOperator>(f, mu, o);
           }), py::arg("surfels"), py::arg("mu"), py::arg("t") = 0.0, py::arg("c_t") = HeatLaplacianOptions{}.c_t,
           py::arg("k") = HeatLaplacianOptions{}.k, py::arg("length_scale") = 0.0, py::arg("per_surface_time") = true,
           py::arg("couple_surfaces") = false, py::arg("kernel") = surface_kernel_name(HeatLaplacianOptions{}.surface_kernel),
           py::arg("stored_weights_bytes") = HeatLaplacianOptions{}.stored_weights_bytes,
           "stored_weights_bytes: keep the kernel's weights when all of them take at most this (0: never); products then\n"
           "skip the distances and Gaussians and give the same values (small surfaces, real labels: many times faster).")
      .def("rows", &surface::MatrixFreeSurfaceOperator::rows)
      .def_property_readonly("t", &surface::MatrixFreeSurfaceOperator::t)
      .def_property_readonly("cut", &surface::MatrixFreeSurfaceOperator::cut)
      .def_property_readonly("mass", &surface::MatrixFreeSurfaceOperator::mass)
      .def_property_readonly("positions", &surface::MatrixFreeSurfaceOperator::positions)
      .def_property_readonly("row_offset", &surface::MatrixFreeSurfaceOperator::row_offset)
      .def_property_readonly("part_t", &surface::MatrixFreeSurfaceOperator::part_t)
      .def("bytes", &surface::MatrixFreeSurfaceOperator::bytes, "Bytes the operator holds: O(N), plus the weights it keeps.")
      .def("matvec", [](const surface::MatrixFreeSurfaceOperator& op, const Eigen::MatrixXd& x) { return surface_product(op, x, false); },
           py::arg("x"), "L x for a vector or an N x b block (one neighbour search for the whole block).")
      .def("stiffness_matvec", [](const surface::MatrixFreeSurfaceOperator& op, const Eigen::MatrixXd& x) { return surface_product(op, x, true); },
           py::arg("x"), "A x = M L x (symmetric) for a vector or an N x b block.")
      .def("bias_corrected_matvec", [](const surface::MatrixFreeSurfaceOperator& op, const Eigen::MatrixXd& x) {
             if (x.rows() != op.rows())
               throw py::value_error("x: expected " + std::to_string(op.rows()) + " rows, got " + std::to_string(x.rows()));
             py::gil_scoped_release release;
             return surface::bias_corrected_laplacian(op, x);
           }, py::arg("x"),
           "L_c x = L x - (t/2) L (I + t L) L x: a pointwise Laplace-Beltrami estimate with the kernel's O(t) bias removed "
           "(three products; digilap.bias_corrected_laplacian).")
      .def("smallest_eigenpairs", [](const surface::MatrixFreeSurfaceOperator& op, int count, double tolerance, int max_iterations) {
        return surface::smallest_eigenpairs(op, spectrum_options(count, tolerance, max_iterations));
      }, py::arg("count") = 10, tolerance_argument(), max_iterations_argument(), Release(), "The count smallest eigenpairs (LOBPCG preconditioned by the surfel graph Laplacian).");
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
}

}  // namespace digilap::python
