// digilap — the heat Laplacian applied without storing it: a 1D fast Gauss transform along the
// arclength (geodesic mode), O(N p) per product instead of O(nnz) = O(N h^(-2/3)).
//
// In geodesic mode, (L g)_i = c [ (G * (mu g))_i - g_i (G * mu)_i ], a Gaussian convolution
// of mu g over the sorted positions S_j along each (periodic) contour, truncated at k sqrt(t)
// exactly as the explicit matrix is (the same window of neighbours, element for element). The
// convolution uses Hermite expansions of the sources of boxes of width sqrt(t), whose moments
// over any run of consecutive sources come from prefix sums; the expansion order p is the
// smallest that meets the error bound epsilon (default 1e-10, relative to the operator's
// scale max|L_ii| max|g|). Contours whose window covers half of them are summed directly.
#pragma once

#include "digilap/heat_laplacian.hpp"
#include "digilap/spectrum.hpp"

#include <Eigen/Core>

#include <vector>

namespace digilap {

class MatrixFreeLaplacian {
public:
  /// Geodesic distance only (throws digilap::Error for Euclidean, Richardson, or epsilon not
  /// in (0, 1)); placement, t, c_t and k as for heat_laplacian().
  MatrixFreeLaplacian(const ContourSet& contours, const Measures& measures, const HeatLaplacianOptions& options = {},
                      double epsilon = 1e-10);

  Eigen::Index rows() const { return mass_.size(); }
  Eigen::Index cols() const { return mass_.size(); }
  double t() const { return t_; }
  double cut() const { return cut_; }
  /// Hermite expansion order used.
  int order() const { return order_; }
  const Eigen::VectorXd& mass() const { return mass_; }
  /// The diagonal of L (to the same accuracy).
  const Eigen::VectorXd& diagonal() const { return diagonal_; }
  const std::vector<Eigen::Index>& row_offset() const { return offset_; }
  const Eigen::MatrixX2d& positions() const { return positions_; }
  /// Arclength coordinate S_i of each row along its contour, in [0, length of the contour).
  const Eigen::VectorXd& arclength() const { return s_; }
  /// Length P of each contour (the period of its arclength coordinate).
  std::vector<double> contour_lengths() const;

  /// y = L x (x and y of size rows(), not aliased). Parallel with OpenMP inside; do not call
  /// it on the same operator from several threads at once (it reuses scratch buffers).
  void apply(const double* x, double* y) const;
  Eigen::VectorXd operator*(const Eigen::VectorXd& x) const;
  /// y = A x = M L x.
  Eigen::VectorXd apply_stiffness(const Eigen::VectorXd& x) const;

private:
  struct Contour {
    Eigen::Index offset = 0, n = 0;
    double P = 0;
    bool direct = false;             // window >= half the contour, or tiny: direct sums
    Eigen::Index boxes = 0;
    std::vector<Eigen::Index> box_start;  // first element of each box (size boxes + 1)
    std::vector<Eigen::Index> box_of;     // box of each element
  };
  // (G * f)_i over the window of each row i (j = i included), into out.
  void gauss_transform(const double* f, double* out) const;

  std::vector<Contour> contours_;
  std::vector<Eigen::Index> offset_;
  Eigen::VectorXd mass_, s_, diagonal_, transform_of_mass_;
  Eigen::MatrixX2d positions_;
  std::vector<Eigen::Index> back_, fwd_;  // the geodesic window of each row
  double t_ = 0, cut_ = 0, delta_ = 0, box_ = 0, scale_ = 0;
  int order_ = 0;
  // Scratch reused by every product: prefix moments (N x order), mu x and its transform.
  // Products on one operator are therefore not thread-safe (each runs in parallel inside).
  mutable std::vector<double> prefix_;
  mutable Eigen::VectorXd weighted_, transformed_;
};

/// The `count` smallest eigenpairs of -A x = lambda M x through the matrix-free operator, on
/// C = M^(1/2) (-L) M^(-1/2). First block LOBPCG preconditioned by the 1D Laplacian along the
/// arclength (its heat-operator form D2 (I + t D2)^-1, a cyclic tridiagonal solve): about 10
/// iterations whatever h. If that has not converged after min(max_iterations, 300) iterations
/// (or N is tiny), Lanczos (Spectra) on c I - C, c = 2 max|L_ii| (Gershgorin), with
/// max_iterations restarts and `subspace` vectors. Converged when every wanted residual
/// |C y - lambda y| <= tolerance * c (LOBPCG), or Spectra's Ritz-value test at `tolerance`.
/// No factorization of L: memory O(N count). Eigenvectors are M-orthonormal; `iterations`
/// and `operations` report the method that answered. Throws digilap::Error for a zero mass or
/// no convergence.
Spectrum smallest_eigenpairs(const MatrixFreeLaplacian& op, const SpectrumOptions& options = {});

/// One implicit Euler heat step (M - dt A) u' = M u solved by Eigen's ConjugateGradient on the
/// matrix-free operator (Jacobi preconditioner), to relative residual `tolerance`.
/// Returns u'; throws digilap::Error if CG does not converge.
Eigen::VectorXd heat_step_cg(const MatrixFreeLaplacian& op, const Eigen::VectorXd& u, double dt,
                             double tolerance = 1e-10, int* iterations = nullptr);

}  // namespace digilap
