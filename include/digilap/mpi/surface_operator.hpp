// digilap — the surface pipeline across MPI ranks on PETSc and SLEPc (issue 24): each rank reads
// only a slab of the volume's planes (plus a halo), computes the normals, areas and operator
// rows of its own surfels, and writes them into distributed PETSc matrices; SLEPc finds the
// smallest eigenpairs. The rows are the one-machine operator's (surface/heat_laplacian.hpp) bit
// for bit, whatever the number of ranks: same components, same l and t, same neighbours summed
// in the same order.
//
// Who reads what: rank r owns the planes [plane_begin, plane_end), chosen so that every rank has
// about N / P surfels (a first pass counts them). It reads its planes plus a halo of
//   ceil(k sqrt(t) / h) + ceil(R / h) + 2 planes on each side
// (the kernel's cut for its rows' neighbours, the II ball for their normals), never the whole
// volume; the components and the length scale are agreed on through small collective
// reductions (a union-find over the components that cross slab boundaries, the 20,000 sampled
// radii of curvature). Memory per rank: about (N / P) (12 nnz_row + 80) bytes for L and A
// (nnz_row the nonzeros per row, docs/distributed.md), plus the slab's runs.
#pragma once

#include "digilap/core/heat_kernel.hpp"
#include "digilap/surface/normals.hpp"
#include "digilap/surface/surfels.hpp"
#include "digilap/surface/volume.hpp"

#include <petscmat.h>

#include <Eigen/Core>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace digilap::mpi {

/// What the one-machine front end takes (apps' options of the same names).
struct DistributedSurfaceOptions {
  surface::VolumeOptions volume;  ///< label or threshold, h, size limit
  std::size_t min_surfels = 0;    ///< drop the surfaces with fewer surfels (--min-size)
  bool largest_only = false;      ///< keep only the largest surface (--largest)
  double k_R = surface::SurfaceNormalOptions{}.k_R;  ///< II radius constant (0: the surfaces' adaptive default)
  double length_scale = 0.0;      ///< l; 0 measures it as surface::length_scale does
  double length_quantile = 0.02;
  /// t, c_t, k, per_contour_time, memory_limit_bytes (per rank). couple_surfaces and
  /// Richardson are refused.
  HeatLaplacianOptions op;
  /// Progress of the stages on stderr, from rank 0.
  bool quiet = true;
};

/// The distributed operator. Rows (and columns) are numbered plane by plane: rank r holds the
/// rows [row_begin, row_end), its surfels in the row order of the whole set (SurfelSet's order
/// before grouping by surface). Owns its PETSc objects.
class DistributedSurfaceOperator {
public:
  DistributedSurfaceOperator() = default;
  DistributedSurfaceOperator(const DistributedSurfaceOperator&) = delete;
  DistributedSurfaceOperator& operator=(const DistributedSurfaceOperator&) = delete;
  DistributedSurfaceOperator(DistributedSurfaceOperator&& other) noexcept;
  DistributedSurfaceOperator& operator=(DistributedSurfaceOperator&& other) noexcept;
  ~DistributedSurfaceOperator();

  Mat L = nullptr;     ///< L_h, N x N, MATMPIAIJ
  Mat A = nullptr;     ///< the stiffness M L, symmetric bit for bit
  Vec mass = nullptr;  ///< mu, the diagonal of M
  MPI_Comm comm = MPI_COMM_NULL;
  std::int64_t size = 0;                    ///< N: surfels of the kept surfaces, all ranks
  std::int64_t row_begin = 0, row_end = 0;  ///< this rank's rows
  std::int64_t plane_begin = 0, plane_end = 0;  ///< this rank's planes
  std::int64_t halo_planes = 0;             ///< planes read beyond them on each side
  std::int64_t planes_read = 0;             ///< planes this rank read in its largest read
  double h = 1.0;
  double length_scale = 0;                  ///< l (measured or given)
  double normal_radius = 0;                 ///< R
  std::vector<double> surface_t;            ///< heat time of each kept surface (numbered by first surfel)
  double k = 6;                             ///< the kernel's cut factor: each surface's cut at k sqrt(its t)
  std::vector<std::int64_t> surface_size;   ///< surfels of each kept surface
  std::int64_t clamped = 0;                 ///< surfels of zero area, all ranks
  std::size_t dropped_surfaces = 0;
  /// This rank's surfels (rows row_begin ...), their surface, area and normal.
  std::vector<surface::Surfel> surfels;
  std::vector<int> surface_of;
  Eigen::VectorXd mu;
  Eigen::MatrixX3d normals;
  /// The heat time of the largest surface (the operator's t, as SurfaceOperator::t).
  double t() const;
};

/// Builds the operator of the volume at `path` on the ranks of `comm` (collective). Throws
/// digilap::Error, on every rank, for what the one-machine pipeline refuses (an empty volume,
/// every surface too small, bad parameters, a memory estimate above the limit on some rank).
DistributedSurfaceOperator distributed_surface_operator(MPI_Comm comm, const std::string& path, const DistributedSurfaceOptions& options);

/// The eigen-solvers measured in docs/distributed.md.
enum class DistributedEigenSolver {
  KrylovSchur,           ///< SLEPc Krylov-Schur on M^(-1/2) (-A) M^(-1/2), products only (the default: the fastest)
  Lobpcg,                ///< SLEPc LOBPCG, Jacobi-preconditioned
  LobpcgAmg,             ///< SLEPc LOBPCG, preconditioned by hypre BoomerAMG on -A + sigma M
  KrylovSchurInvert,     ///< SLEPc Krylov-Schur, shift-and-invert by a MUMPS Cholesky factor
};
/// "krylov-schur", "lobpcg", "lobpcg-amg" or "shift-invert".
DistributedEigenSolver distributed_eigen_solver_by_name(const std::string& name);

struct DistributedSpectrum {
  Eigen::VectorXd eigenvalues;       ///< of -A x = lambda M x, ascending, one 0 per kept surface first
  Eigen::VectorXd laplace_beltrami;  ///< -ln(1 - lambda t_c) / t_c, t_c of the surface holding the eigenvector
  Eigen::MatrixXd eigenvectors;      ///< this rank's rows, M-orthonormal (zero-area surfels: their neighbours' average)
  int iterations = 0;
  double tolerance = 0;
  std::string solver;
};

/// The `count` smallest eigenpairs (collective): each kept surface's constant vector is exact
/// and deflated from SLEPc's search; zero-area surfels are left out of the problem (their rows
/// and columns of A are zero) and filled in afterwards. Throws digilap::Error when SLEPc does
/// not converge. `progress`, when given, is called on every rank after each SLEPc iteration with
/// the iteration and the number of eigenpairs converged so far (of count minus the surfaces).
DistributedSpectrum distributed_smallest_eigenpairs(const DistributedSurfaceOperator& op, int count,
                                                    DistributedEigenSolver solver = DistributedEigenSolver::KrylovSchur,
                                                    double tolerance = 1e-9,
                                                    const std::function<void(int iteration, int converged)>& progress = {});

}  // namespace digilap::mpi
