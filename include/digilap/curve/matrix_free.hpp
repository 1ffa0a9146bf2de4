// digilap — the heat Laplacian applied without storing it: a 1D fast Gauss transform along the
// arclength (geodesic mode), O(N p) per product instead of O(nnz) = O(N h^(-2/3)).
//
// In geodesic mode, (L g)_i = c [ (G * (mu g))_i - g_i (G * mu)_i ], a Gaussian convolution
// of mu g over the sorted positions S_j along each (periodic) contour, truncated at k sqrt(t)
// exactly as the explicit matrix is (the same window of neighbours, element for element). The
// convolution splits each window into whole boxes of width <= sqrt(t), which every target of
// a box sees (Hermite expansions translated to a Taylor expansion about the box), and its two
// ends, where the windows of the box's targets differ (a series in the product of the target's
// and the source's offsets, after the Gaussian is factored about the end's centre: ~6 terms,
// over one box; the source or two a window reaches past that box are added term by term).
// Orders are the smallest that meet the error bound epsilon (default 1e-10, relative to the
// operator's scale max|L_ii| max|g|). Contours whose window covers half of them are summed
// directly.
#pragma once

#include "digilap/curve/heat_laplacian.hpp"
#include "digilap/curve/spectrum.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <memory>
#include <vector>

namespace digilap {
inline namespace curve {

class MatrixFreeLaplacian {
public:
  /// Geodesic distance only (throws digilap::Error for Euclidean, Richardson, or epsilon not
  /// in (0, 1)); placement, t, c_t and k as for heat_laplacian().
  MatrixFreeLaplacian(const ContourSet& contours, const Measures& measures, const HeatLaplacianOptions& options = {},
                      double epsilon = 1e-10);
  ~MatrixFreeLaplacian();
  MatrixFreeLaplacian(const MatrixFreeLaplacian& other);  ///< a deep copy (its own scratch)
  MatrixFreeLaplacian& operator=(const MatrixFreeLaplacian& other);
  MatrixFreeLaplacian(MatrixFreeLaplacian&&) noexcept;
  MatrixFreeLaplacian& operator=(MatrixFreeLaplacian&&) noexcept;

  Eigen::Index rows() const;
  Eigen::Index cols() const;
  /// Heat time: the contour with the most rows' when each contour has its own (contour_t()).
  double t() const;
  /// Heat time of each contour (HeatLaplacianOptions::per_contour_time), as the explicit operator's.
  std::vector<double> contour_t() const;
  /// The length scale l behind the default t (0 when t was given).
  double length_scale() const;
  double cut() const;
  /// Hermite expansion order used for whole boxes.
  int order() const;
  /// Largest series order used at the window ends (0 when every contour is summed directly).
  int band_order() const;
  /// Whether products run the AVX2 + FMA build of their loops (x86-64 CPUs that have both,
  /// unless the environment sets DIGILAP_PLAIN_KERNELS=1); results agree with the plain build
  /// to about 1e-14 of the operator's scale.
  bool wide_kernels() const;
  /// Share of the rows whose window is summed term by term (small contours, degenerate boxes).
  double direct_share() const;
  const Eigen::VectorXd& mass() const;
  /// The diagonal of L (to the same accuracy).
  const Eigen::VectorXd& diagonal() const;
  const std::vector<Eigen::Index>& row_offset() const;
  const Eigen::MatrixX2d& positions() const;
  /// Arclength coordinate S_i of each row along its contour, in [0, length of the contour).
  const Eigen::VectorXd& arclength() const;
  /// Whether every element of contour c interacts with the next one (the cut reaches it):
  /// the contour's block is then one connected component, with the constants as its kernel.
  bool contour_is_connected(std::size_t c) const;
  /// Length P of each contour (the period of its arclength coordinate).
  std::vector<double> contour_lengths() const;

  /// y = L x (x and y of size rows(), not aliased). Parallel with OpenMP inside; do not call
  /// it on the same operator from several threads at once (it reuses scratch buffers).
  void apply(const double* x, double* y) const;
  Eigen::VectorXd operator*(const Eigen::VectorXd& x) const;
  /// y = L_c x for the block of contour c alone (x and y of its n_c rows, not aliased): the
  /// operator is block-diagonal by contour. Same threading caveat as apply().
  void apply_contour(std::size_t c, const double* x, double* y) const;
  /// Y = L_c X column by column, for an n_c x b block: the columns in parallel, each product
  /// on one thread with scratch of its own (with b >= the thread count, this scales better
  /// than the products one after another, each parallel inside). The same result, bit for
  /// bit, as apply_contour() on each column. Throws digilap::Error for a block whose row
  /// count is not n_c or a contour that does not exist. Same threading caveat as apply().
  void apply_contour_block(std::size_t c, const Eigen::MatrixXd& x, Eigen::MatrixXd& y) const;
  /// y = A x = M L x.
  Eigen::VectorXd apply_stiffness(const Eigen::VectorXd& x) const;

private:
  // The plan (boxes, bands, expansion tables, the windows) and the products' scratch, behind a
  // pointer so that the header shows the API only (lib/curve/matrix_free_plan.hpp).
  struct Plan;
  std::unique_ptr<Plan> plan_;
};

/// The `count` smallest eigenpairs of -A x = lambda M x through the matrix-free operator,
/// contour by contour (the operator is block-diagonal by contour), merged so that repeated
/// eigenvalues of identical contours all count; contours of up to 400 rows are solved densely.
/// On each larger contour, on C = M^(1/2) (-L_c) M^(-1/2): first block LOBPCG preconditioned by the 1D Laplacian along the
/// arclength (its heat-operator form D2 (I + t D2)^-1, a cyclic tridiagonal solve): about 10
/// iterations whatever h. If that has not converged after min(max_iterations, 300) iterations
/// (or N is tiny), Lanczos (Spectra) on c I - C, c = 2 max|L_ii| (Gershgorin), with
/// max_iterations restarts and `subspace` vectors. Converged when every wanted residual
/// |C y - lambda y| <= tolerance * c (LOBPCG), or Spectra's Ritz-value test at `tolerance`.
/// No factorization of L: memory O(N count). Eigenvectors are M-orthonormal; `iterations`
/// and `operations` report the method that answered (summed over contours); eigenvectors have
/// a fixed sign (largest entry positive), and the result does not depend on the number of
/// threads. Throws digilap::Error for a zero mass, no convergence, or a contour whose
/// elements do not interact (a cut below the spacing of consecutive elements).
Spectrum smallest_eigenpairs(const MatrixFreeLaplacian& op, const SpectrumOptions& options = {});

/// The spectrum of each contour on its own: element c holds the min(count, n_c) smallest
/// eigenpairs of contour c, on its n_c rows.
std::vector<Spectrum> smallest_eigenpairs_per_contour(const MatrixFreeLaplacian& op, const SpectrumOptions& options = {});

/// One implicit Euler heat step (M - dt A) u' = M u solved by Eigen's ConjugateGradient on the
/// matrix-free operator (Jacobi preconditioner), to relative residual `tolerance`.
/// Returns u'; throws digilap::Error if CG does not converge.
Eigen::VectorXd heat_step_cg(const MatrixFreeLaplacian& op, const Eigen::VectorXd& u, double dt,
                             double tolerance = 1e-10, int* iterations = nullptr);

}  // namespace curve
}  // namespace digilap
