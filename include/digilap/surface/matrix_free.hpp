// digilap — the surface operator of heat_laplacian() applied without storing it (issue 23).
//
// The assembled operator holds k^2 pi t / h^2 nonzeros a row (about 1,300 at h = 0.025 on the
// unit sphere, 24 bytes each for L and A): its memory, not its arithmetic, is what a mesh FEM
// with 7 a row does not pay. Here each product finds a row's neighbours in the same uniform grid,
// evaluates the Gaussian once per pair and applies it to every column of the block, so memory is
// O(N) and a block of b vectors costs one neighbour search for b products:
//
//   (A x)_i = mu_i sum_{|x_i - x_j| <= cut} w_ij mu_j (x_j - x_i),   (L x)_i = the same without mu_i,
//
// which is the assembled A x and L x up to rounding (1e-15 of |A| |x|: the same terms, the
// diagonal -sum_j w_ij mu_j applied as one term, the factor mu_i applied last).
// Rows go 4 at a time (neighbouring surfels sharing their neighbours' loads), each summed in a
// fixed order: the result does not depend on the number of threads, bit for bit.
#pragma once

#include "digilap/core/bias_correction.hpp"
#include "digilap/core/spectrum.hpp"
#include "digilap/surface/heat_laplacian.hpp"

#include <Eigen/Core>

#include <memory>
#include <vector>

namespace digilap::surface {

namespace detail {
struct SurfacePart;  // one surface's grid, kernel and weights (lib/surface/matrix_free.cpp)
}

class MatrixFreeSurfaceOperator {
public:
  /// The operator heat_laplacian(surfels, measures, options) would assemble: the same parts,
  /// heat times, cut and measures. Throws digilap::Error as heat_laplacian does.
  MatrixFreeSurfaceOperator(const SurfelSet& surfels, const SurfelMeasures& measures, const HeatLaplacianOptions& options = {});
  ~MatrixFreeSurfaceOperator();
  MatrixFreeSurfaceOperator(MatrixFreeSurfaceOperator&&) noexcept;
  MatrixFreeSurfaceOperator& operator=(MatrixFreeSurfaceOperator&&) noexcept;

  Eigen::Index rows() const { return mass_.size(); }
  const Eigen::VectorXd& mass() const { return mass_; }
  /// Heat time and cut of the largest surface, its length scale (0 when t was given).
  double t() const { return t_; }
  double cut() const { return cut_; }
  double length_scale() const { return length_scale_; }
  /// The grid step of the surfels and their centres.
  double h() const { return h_; }
  const Eigen::MatrixX3d& positions() const { return positions_; }
  /// Each surface's rows [row_offset[p], row_offset[p + 1]) and heat time.
  const std::vector<Eigen::Index>& row_offset() const { return row_offset_; }
  const std::vector<double>& part_t() const { return part_t_; }
  /// The kernel's cut on surface p, k sqrt(t_p).
  double part_cut(std::size_t p) const;
  std::size_t parts() const { return row_offset_.size() - 1; }
  /// The diagonal of A (minus the row's other entries summed; 0 for a surfel of zero area).
  const Eigen::VectorXd& stiffness_diagonal() const { return a_diagonal_; }
  /// The sum of each row's off-diagonal entries of L, sum_{j != i} w_ij mu_j (= -L_ii).
  const Eigen::VectorXd& laplacian_row_sums() const { return l_row_sums_; }
  /// Bytes held by the operator (positions, masses, grids): O(N).
  double bytes() const;

  /// Y = A X and Y = L X for a block X of rows() x b (not aliased with Y).
  void apply_stiffness(const Eigen::MatrixXd& x, Eigen::MatrixXd& y) const;
  void apply_laplacian(const Eigen::MatrixXd& x, Eigen::MatrixXd& y) const;
  /// The same on surface p alone: X and Y hold its rows only (the operator is block-diagonal).
  void apply_part(std::size_t p, const Eigen::MatrixXd& x, Eigen::MatrixXd& y, bool stiffness) const;
  /// Surface p's internals (the library's own use: its spectrum's coarse start).
  const detail::SurfacePart& part(std::size_t p) const;

private:
  std::vector<std::unique_ptr<detail::SurfacePart>> part_;
  Eigen::MatrixX3d positions_;
  Eigen::VectorXd mass_, a_diagonal_, l_row_sums_;
  std::vector<Eigen::Index> row_offset_;
  std::vector<double> part_t_;
  double t_ = 0, cut_ = 0, length_scale_ = 0, h_ = 1;
};

/// The `count` smallest eigenpairs of -A x = lambda M x from products alone: block LOBPCG on
/// each surface's support of mu, preconditioned by T = (K + sigma M)^(-1) + t, K the graph
/// Laplacian of edge-adjacent surfels (7 nonzeros a row, factorized once): the heat operator's
/// eigenvalues are (1 - e^(-lambda t)) / t ~ lambda / (1 + lambda t), whose inverse is
/// 1 / lambda + t, so T C stays within a small factor of 1 over the whole spectrum and LOBPCG
/// needs a third of the products it needs unpreconditioned. On large smooth surfaces it starts
/// from the eigenvectors of the same kernel on aggregates of about 2 x 2 surfels
/// (SpectrumOptions::coarse_start). With the conventions of smallest_eigenpairs(const HeatOperator&): eigenvectors
/// M-orthonormal, zero-area surfels given the heat-kernel average of their neighbours,
/// laplace_beltrami per surface's t. The same eigenvalues as the assembled operator's to the
/// solver's tolerance; where zero-area surfels cut a surface, each piece is solved on its own
/// (one zero eigenvalue each), as the assembled operator's components are. Throws
/// digilap::Error for a count out of range, a surface without area, or no convergence within
/// options.max_iterations.
Spectrum smallest_eigenpairs(const MatrixFreeSurfaceOperator& op, const SpectrumOptions& options = {});

/// The pointwise estimate L_c g = L g − (t/2) L (I + t L) L g with the kernel's O(t) bias
/// removed (core/bias_correction.hpp), each surface with its own t: three products, memory O(N).
/// With `plain`, also L g (the first product).
Eigen::MatrixXd bias_corrected_laplacian(const MatrixFreeSurfaceOperator& op, const Eigen::MatrixXd& g,
                                         Eigen::MatrixXd* plain = nullptr);

}  // namespace digilap::surface
