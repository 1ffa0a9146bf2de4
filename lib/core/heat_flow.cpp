#include "digilap/core/heat_flow.hpp"

#include "digilap/core/error.hpp"
#include "components.hpp"
#include "conjugate_gradients.hpp"
#include "massless.hpp"
#include "eigen_checks.hpp"

#include <Eigen/Dense>

#include <cmath>

namespace digilap {

namespace {
constexpr double kCgTolerance = 1e-12;  // relative residual of each step: far below the scheme's error
void check_step(double dt) { require_positive("HeatFlow: the time step dt", dt); }
}  // namespace

HeatFlow::HeatFlow(const SparseMatrix& A, const Eigen::VectorXd& mass, double dt, TimeScheme scheme, HeatSolver solver)
    : dt_(dt) {
  check_step(dt);
  for (Eigen::Index i = 0; i < mass.size(); ++i)
    if (!(mass[i] > 0))
      throw Error("HeatFlow: the mass of row " + std::to_string(i) +
                  " is not > 0 (an element of zero measure has no equation in (A, M)): build the flow from the operator "
                  "(HeatFlow(op, dt)), which steps such elements with their row of L");
  prepare(A, mass, scheme, solver == HeatSolver::Auto ? HeatSolver::Factorization : solver);
}

HeatFlow::HeatFlow(const HeatOperator& op, double dt, TimeScheme scheme, HeatSolver solver) : dt_(dt) {
  check_step(dt);
  if (op.A.rows() != op.rows() || op.mass.size() != op.rows())
    throw Error("HeatFlow: the operator has no stiffness A (assembled with stiffness = false) or no masses");
  detail::check_masses(op.mass, "HeatFlow");
  massless_ = op.massless_rows();
  detail::check_massless_reach_mass(op, massless_, "HeatFlow");
  if (solver == HeatSolver::Auto) solver = op.dimension >= 2 ? HeatSolver::ConjugateGradient : HeatSolver::Factorization;
  prepare(op.A, op.mass, scheme, solver);
  if (!massless_.empty()) {
    L_massless_.resize(static_cast<Eigen::Index>(massless_.size()), op.rows());
    for (std::size_t k = 0; k < massless_.size(); ++k) L_massless_.row(static_cast<Eigen::Index>(k)) = op.L.row(massless_[k]);
  }
}

void HeatFlow::prepare(const SparseMatrix& A, const Eigen::VectorXd& mass, TimeScheme scheme, HeatSolver solver) {
  if (A.rows() != mass.size() || A.cols() != mass.size())
    throw Error("HeatFlow: A and the masses have different sizes");
  theta_ = scheme == TimeScheme::ImplicitEuler ? 1.0 : 0.5;
  solver_kind_ = solver;
  mass_ = mass;
  A_ = A;
  // The components of the flow, each with its total mass: its heat sum_i mu_i u_i is conserved.
  const detail::Components components = detail::connected_components(A);
  component_of_row_ = components.of_row;
  component_mass_.assign(components.rows.size(), 0.0);
  for (Eigen::Index i = 0; i < mass.size(); ++i)
    if (mass[i] > 0) component_mass_[component_of_row_[i]] += mass[i];
  // A massless row and column of M - theta dt A vanish: put 1 on its diagonal, which decouples
  // it (its value is then set from L in step()).
  lhs_diagonal_ = mass - (theta_ * dt_) * A.diagonal();
  for (Eigen::Index i : massless_) lhs_diagonal_[i] = 1.0;
  if (solver == HeatSolver::ConjugateGradient) {
    inverse_diagonal_.resize(mass.size());
    for (Eigen::Index i = 0; i < mass.size(); ++i) {
      if (!(lhs_diagonal_[i] > 0))
        throw Error("HeatFlow: M - theta dt A has a diagonal entry that is not > 0 (A must be negative semidefinite and M >= 0)");
      inverse_diagonal_[i] = 1.0 / lhs_diagonal_[i];
    }
    return;
  }
  ColMatrix M(mass.size(), mass.size());
  M.reserve(Eigen::VectorXi::Ones(mass.size()));
  for (Eigen::Index i = 0; i < mass.size(); ++i) M.insert(i, i) = mass[i] > 0 ? mass[i] : 0.0;
  ColMatrix lhs = M - (theta_ * dt_) * ColMatrix(A);
  for (Eigen::Index i : massless_) lhs.coeffRef(i, i) = 1.0;  // on M's diagonal: no insertion
  solver_.compute(lhs);
  if (solver_.info() != Eigen::Success)
    throw Error("HeatFlow: the factorization of M - theta dt A failed (A must be negative semidefinite and M >= 0)");
}

// Each step by conjugate gradients (lib/core/conjugate_gradients.hpp) from the previous state,
// which is within dt of the answer. The product's rows run in parallel, each summed in order:
// the same bits for any thread count.
Eigen::VectorXd HeatFlow::solve(const Eigen::VectorXd& b, const Eigen::VectorXd& guess) const {
  const Eigen::Index n = b.size();
  const int* outer = A_.outerIndexPtr();
  const int* inner = A_.innerIndexPtr();
  const double* value = A_.valuePtr();
  const double c = theta_ * dt_;
  // y = (M - theta dt A) x, the diagonal from lhs_diagonal_ (which holds the massless rows' 1).
  auto apply = [&](const Eigen::VectorXd& x, Eigen::VectorXd& y) {
#pragma omp parallel for schedule(static, 1024)
    for (Eigen::Index i = 0; i < n; ++i) {
      double sum = 0;
      for (int e = outer[i]; e < outer[i + 1]; ++e)
        if (inner[e] != i) sum += value[e] * x[inner[e]];
      y[i] = lhs_diagonal_[i] * x[i] - c * sum;
    }
  };
  Eigen::VectorXd x = guess;
  // CG needs about sqrt(cond) iterations, cond(M - theta dt A) <= 1 + 2 theta dt max(-A_ii / m_i):
  // a few for dt near t; the limit only stops a hopeless case.
  constexpr int kLimit = 10000;
  last_iterations_ = detail::conjugate_gradients(apply, inverse_diagonal_, b, x, kCgTolerance, kLimit);
  if (last_iterations_ < 0)
    throw Error("HeatFlow: conjugate gradients did not reach 1e-12 in " + std::to_string(kLimit) +
                " iterations (dt is very large against the heat time t); use a smaller dt or HeatSolver::Factorization");
  return x;
}

Eigen::VectorXd HeatFlow::step(const Eigen::VectorXd& u) const {
  if (u.size() != A_.rows()) throw Error("HeatFlow::step: the vector has the wrong size");
  // M u + (1 - theta) dt A u, massless rows 0 (their column of A is 0 and their mass too).
  const Eigen::VectorXd rhs = mass_.cwiseMax(0.0).cwiseProduct(u) + ((1.0 - theta_) * dt_) * (A_ * u);
  Eigen::VectorXd next = solver_kind_ == HeatSolver::ConjugateGradient ? solve(rhs, u) : Eigen::VectorXd(solver_.solve(rhs));
  conserve_heat(u, next);
  if (!massless_.empty()) {
    // u_i' (1 - theta dt L_ii) = u_i + dt ((1 - theta) (L u)_i + theta sum_{j != i} L_ij u_j'),
    // where the u_j' with L_ij != 0 all have mass (L_ij = w mu_j) and are already known.
    const Eigen::VectorXd Lu = L_massless_ * u;
    for (std::size_t k = 0; k < massless_.size(); ++k) next[massless_[k]] = 0.0;
    const Eigen::VectorXd Lnext = L_massless_ * next;
    for (std::size_t k = 0; k < massless_.size(); ++k) {
      const Eigen::Index i = massless_[k];
      const double lii = L_massless_.coeff(static_cast<Eigen::Index>(k), i);
      next[i] = (u[i] + dt_ * ((1 - theta_) * Lu[static_cast<Eigen::Index>(k)] + theta_ * Lnext[static_cast<Eigen::Index>(k)])) /
                (1 - theta_ * dt_ * lii);
    }
  }
  return next;
}

// sum_i mu_i u_i is invariant under the flow (1^T A = 0 on each component), but the solve
// loses it when dt is so large that M - theta dt A is nearly the singular dt A: the constants
// are its near-kernel, and the rounding of the solve lands there (total heat 0.76 -> 0.83 at
// dt = 1e13, -0.28 at 1e15 on the circle). The heat of each component is put back exactly
// by a constant shift, which is the direction that rounding takes.
void HeatFlow::conserve_heat(const Eigen::VectorXd& u, Eigen::VectorXd& next) const {
  std::vector<double> change(component_mass_.size(), 0.0);
  for (Eigen::Index i = 0; i < u.size(); ++i)
    if (mass_[i] > 0) change[component_of_row_[i]] += mass_[i] * (next[i] - u[i]);
  for (Eigen::Index i = 0; i < u.size(); ++i) {
    const int c = component_of_row_[i];
    if (component_mass_[c] > 0) next[i] -= change[c] / component_mass_[c];
  }
}

Eigen::VectorXd HeatFlow::advance(const Eigen::VectorXd& u0, int steps) const {
  if (steps < 0) throw Error("HeatFlow::advance: steps must be >= 0");
  Eigen::VectorXd u = u0;
  for (int s = 0; s < steps; ++s) u = step(u);
  return u;
}

Eigen::VectorXd heat_flow_spectral(const Spectrum& spectrum, const Eigen::VectorXd& mass, const Eigen::VectorXd& u0,
                                   double tau) {
  if (u0.size() != mass.size() || spectrum.eigenvectors.rows() != mass.size())
    throw Error("heat_flow_spectral: sizes do not match");
  const Eigen::VectorXd coefficients = spectrum.eigenvectors.transpose() * mass.cwiseProduct(u0);
  const Eigen::VectorXd decay = (-tau * spectrum.eigenvalues.array()).exp();
  return spectrum.eigenvectors * coefficients.cwiseProduct(decay);
}

Eigen::VectorXd heat_flow_dense(const SparseMatrix& A, const Eigen::VectorXd& mass, const Eigen::VectorXd& u0,
                                double tau) {
  const Eigen::Index n = mass.size();
  if (n > 5000) throw Error("heat_flow_dense: N = " + std::to_string(n) + " is above 5000 (O(N^3)); use HeatFlow");
  if (u0.size() != n || A.rows() != n) throw Error("heat_flow_dense: sizes do not match");
  const Eigen::MatrixXd K = -Eigen::MatrixXd(A);
  const Eigen::MatrixXd M = mass.asDiagonal();
  Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> eig(K, M);
  if (eig.info() != Eigen::Success) throw Error("heat_flow_dense: the eigendecomposition failed");
  const Eigen::MatrixXd& V = eig.eigenvectors();  // M-orthonormal
  const Eigen::VectorXd c = V.transpose() * mass.cwiseProduct(u0);
  return V * c.cwiseProduct((-tau * eig.eigenvalues().array()).exp().matrix());
}

double modal_amplitude(const Eigen::VectorXd& u, const Eigen::VectorXd& phi, const Eigen::VectorXd& mass) {
  return u.dot(mass.cwiseProduct(phi)) / phi.dot(mass.cwiseProduct(phi));
}

}  // namespace digilap
