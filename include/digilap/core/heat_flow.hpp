// digilap — heat diffusion du/dtau = L u on contours and surfaces, with the pair (A, M) (SPEC §4, §7).
//
// Time stepping solves M u_{n+1} - theta dt A u_{n+1} = M u_n + (1 - theta) dt A u_n,
// theta = 1 (implicit Euler, first order, monotone) or 1/2 (Crank-Nicolson, second order).
// The matrix M - theta dt A is symmetric positive definite. On curves it is factorized once
// (sparse LDL^T, banded: no fill-in) in the constructor and reused by every step, as
// geometry-central's solvers do. On surfaces the factors fill in (1.96 GB and 187 s at 20,036
// surfels for an operator of 0.44 GB), so each step is solved by conjugate gradients with a
// Jacobi preconditioner instead: memory O(N) beyond A, and few iterations because M dominates
// the matrix for the steps a flow takes (dt A / M is about dt / t). HeatSolver chooses.
// The heat sum_i mu_i u_i of each connected component (each contour, in geodesic mode) is
// conserved to rounding for every dt: the solve alone loses it when dt A dwarfs M.
//
// Elements of measure mu = 0 (noisy contours, thin parts of a segmentation: core/operator.hpp)
// have no equation in the pair (A, M): their rows and columns of A vanish. Built from an
// operator (any dimension), the flow gives them their own row of L instead, du_i/dtau = (L u)_i,
// stepped with the same scheme once the others are known (they do not influence the others,
// having no mass).
#pragma once

#include "digilap/core/operator.hpp"
#include "digilap/core/spectrum.hpp"

#include <Eigen/Core>
#include <Eigen/SparseCholesky>

namespace digilap {

enum class TimeScheme { ImplicitEuler, CrankNicolson };

/// How each step's system (M - theta dt A) u' = b is solved.
enum class HeatSolver {
  Auto,               ///< from an operator: factorization on curves, conjugate gradients on surfaces; from (A, M): factorization
  Factorization,      ///< sparse LDL^T once, two triangular solves per step (fast when the factors stay sparse)
  ConjugateGradient,  ///< Jacobi-preconditioned CG per step to 1e-12 relative residual (memory O(N) beyond A)
};

class HeatFlow {
public:
  /// From the pair (A, M). Throws digilap::Error for dt not > 0 and finite, mismatched sizes,
  /// a mass that is not > 0 (build the flow from the operator, which steps such rows with their
  /// row of L), or a failed factorization (A not negative semidefinite).
  HeatFlow(const SparseMatrix& A, const Eigen::VectorXd& mass, double dt, TimeScheme scheme = TimeScheme::CrankNicolson,
           HeatSolver solver = HeatSolver::Auto);
  /// From an operator of any dimension; handles elements of zero measure through L (see above).
  /// Throws digilap::Error as above, for an operator without A, or for a zero-mass row with no
  /// neighbour with mass within the cut (a part with no mass at all).
  HeatFlow(const HeatOperator& op, double dt, TimeScheme scheme = TimeScheme::CrankNicolson,
           HeatSolver solver = HeatSolver::Auto);

  double dt() const { return dt_; }
  /// The solver in use (Auto resolved).
  HeatSolver solver() const { return solver_kind_; }
  /// Conjugate-gradient iterations of the last step (0 with the factorization).
  int last_iterations() const { return last_iterations_; }
  /// One step from u.
  Eigen::VectorXd step(const Eigen::VectorXd& u) const;
  /// `steps` steps from u0, i.e. to time steps * dt.
  Eigen::VectorXd advance(const Eigen::VectorXd& u0, int steps) const;

private:
  using ColMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;
  void prepare(const SparseMatrix& A, const Eigen::VectorXd& mass, TimeScheme scheme, HeatSolver solver);
  Eigen::VectorXd solve(const Eigen::VectorXd& b, const Eigen::VectorXd& guess) const;
  void conserve_heat(const Eigen::VectorXd& u, Eigen::VectorXd& next) const;
  // One copy of A serves both sides, M u + (1 - theta) dt A u and, for conjugate gradients,
  // M x - theta dt A x: on a surface A is most of the memory, and two combined matrices would
  // double it.
  SparseMatrix A_;
  HeatSolver solver_kind_ = HeatSolver::Factorization;
  Eigen::SimplicialLDLT<ColMatrix> solver_;  // the factorization
  Eigen::VectorXd lhs_diagonal_;             // M - theta dt A's diagonal (1 on massless rows)
  Eigen::VectorXd inverse_diagonal_;         // its inverse: the Jacobi preconditioner
  mutable int last_iterations_ = 0;
  double dt_;
  double theta_ = 0.5;
  std::vector<Eigen::Index> massless_;  // rows of zero measure, stepped with their row of L
  SparseMatrix L_massless_;             // those rows of L
  Eigen::VectorXd mass_;
  std::vector<int> component_of_row_;   // connected components of A: heat is conserved on each
  std::vector<double> component_mass_;
};

/// exp(tau L) u0 through a set of eigenpairs (M-orthonormal): sum_k exp(-lambda_k tau)
/// phi_k phi_k^T M u0. Exact for the components the eigenpairs span.
Eigen::VectorXd heat_flow_spectral(const Spectrum& spectrum, const Eigen::VectorXd& mass,
                                   const Eigen::VectorXd& u0, double tau);

/// exp(tau L) u0 exactly, from the dense generalized eigendecomposition of (-A, M): O(N^3),
/// for reference on small problems. Throws digilap::Error above N = 5000.
Eigen::VectorXd heat_flow_dense(const SparseMatrix& A, const Eigen::VectorXd& mass, const Eigen::VectorXd& u0,
                                double tau);

/// Amplitude of u along the mode phi in the M inner product: <u, phi>_M / <phi, phi>_M.
double modal_amplitude(const Eigen::VectorXd& u, const Eigen::VectorXd& phi, const Eigen::VectorXd& mass);

}  // namespace digilap
