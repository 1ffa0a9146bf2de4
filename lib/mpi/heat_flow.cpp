// Heat flow across ranks with PETSc's KSP (mpi/heat_flow.hpp): the one-machine scheme of
// core/heat_flow.cpp, step for step.
#include "digilap/mpi/heat_flow.hpp"

#include "digilap/core/error.hpp"

#include "collectives.hpp"

#include <cmath>
#include <string>

namespace digilap::mpi {

using detail::all_reduce;
using detail::petsc_check;
using detail::Ranks;

namespace {
constexpr double kCgTolerance = 1e-12;  // relative residual of each step, as on one machine
constexpr PetscInt kCgLimit = 10000;

// Copies this rank's entries between an Eigen vector and a PETSc one.
void to_petsc(const Eigen::VectorXd& from, Vec to) {
  PetscScalar* a;
  petsc_check(VecGetArray(to, &a), "VecGetArray");
  for (Eigen::Index i = 0; i < from.size(); ++i) a[i] = from[i];
  petsc_check(VecRestoreArray(to, &a), "VecRestoreArray");
}
Eigen::VectorXd from_petsc(Vec from, Eigen::Index n) {
  const PetscScalar* a;
  petsc_check(VecGetArrayRead(from, &a), "VecGetArrayRead");
  Eigen::VectorXd out = Eigen::Map<const Eigen::VectorXd>(a, n);
  petsc_check(VecRestoreArrayRead(from, &a), "VecRestoreArrayRead");
  return out;
}
}  // namespace

DistributedHeatFlow::DistributedHeatFlow(const DistributedSurfaceOperator& op, double dt, TimeScheme scheme,
                                         DistributedPreconditioner preconditioner)
    : op_(op), dt_(dt), theta_(scheme == TimeScheme::ImplicitEuler ? 1.0 : 0.5) {
  if (!(dt > 0) || !std::isfinite(dt)) throw Error("DistributedHeatFlow: dt must be > 0 and finite, got " + std::to_string(dt));
  // M - theta dt A; zero-area rows (all zero in A and M) get a 1 so that the system stays
  // definite: their value is computed from L after the solve.
  petsc_check(MatDuplicate(op.A, MAT_COPY_VALUES, &system_), "MatDuplicate");
  petsc_check(MatScale(system_, -theta_ * dt_), "MatScale");
  petsc_check(MatSetOption(system_, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE), "MatSetOption");
  petsc_check(MatCreateVecs(op.A, &u_, &b_), "MatCreateVecs");
  petsc_check(VecDuplicate(u_, &x_), "VecDuplicate");
  petsc_check(VecDuplicate(u_, &work_), "VecDuplicate");
  const Eigen::Index n = op.mu.size();
  Eigen::VectorXd diagonal = op.mu;
  for (Eigen::Index i = 0; i < n; ++i)
    if (!(op.mu[i] > 0)) diagonal[i] = 1.0;
  to_petsc(diagonal, work_);
  petsc_check(MatDiagonalSet(system_, work_, ADD_VALUES), "MatDiagonalSet");
  petsc_check(MatSetOption(system_, MAT_SYMMETRIC, PETSC_TRUE), "MatSetOption");
  petsc_check(KSPCreate(op.comm, &ksp_), "KSPCreate");
  petsc_check(KSPSetOperators(ksp_, system_, system_), "KSPSetOperators");
  petsc_check(KSPSetType(ksp_, KSPCG), "KSPSetType");
  petsc_check(KSPSetTolerances(ksp_, kCgTolerance, 0.0, PETSC_DEFAULT, kCgLimit), "KSPSetTolerances");
  petsc_check(KSPSetInitialGuessNonzero(ksp_, PETSC_TRUE), "KSPSetInitialGuessNonzero");  // from u: one step's change is small
  PC pc;
  petsc_check(KSPGetPC(ksp_, &pc), "KSPGetPC");
  if (preconditioner == DistributedPreconditioner::Amg) {
    petsc_check(PCSetType(pc, PCHYPRE), "PCSetType");
    petsc_check(PCHYPRESetType(pc, "boomeramg"), "PCHYPRESetType");
  } else {
    petsc_check(PCSetType(pc, PCJACOBI), "PCSetType");
  }
  petsc_check(KSPSetOptionsPrefix(ksp_, "heat_"), "KSPSetOptionsPrefix");  // -heat_ksp_* / -heat_pc_* still apply
  petsc_check(KSPSetFromOptions(ksp_), "KSPSetFromOptions");
  surface_area_.assign(op.surface_t.size(), 0.0);
  for (Eigen::Index i = 0; i < n; ++i) surface_area_[static_cast<std::size_t>(op.surface_of[static_cast<std::size_t>(i)])] += op.mu[i];
  all_reduce(Ranks(op.comm), surface_area_, MPI_SUM);
}

DistributedHeatFlow::~DistributedHeatFlow() {
  KSPDestroy(&ksp_);
  MatDestroy(&system_);
  VecDestroy(&u_), VecDestroy(&b_), VecDestroy(&x_), VecDestroy(&work_);
}

Eigen::VectorXd DistributedHeatFlow::step(const Eigen::VectorXd& u) const {
  const Eigen::Index n = op_.mu.size();
  if (u.size() != n)
    throw Error("DistributedHeatFlow::step: u has " + std::to_string(u.size()) + " entries, this rank holds " + std::to_string(n) + " rows");
  // b = M u + (1 - theta) dt A u, solved from the guess u.
  to_petsc(u, u_);
  petsc_check(MatMult(op_.A, u_, work_), "MatMult");
  petsc_check(VecPointwiseMult(b_, op_.mass, u_), "VecPointwiseMult");
  petsc_check(VecAXPY(b_, (1 - theta_) * dt_, work_), "VecAXPY");
  petsc_check(VecCopy(u_, x_), "VecCopy");
  petsc_check(KSPSolve(ksp_, b_, x_), "KSPSolve");
  KSPConvergedReason reason;
  PetscInt iterations = 0;
  petsc_check(KSPGetConvergedReason(ksp_, &reason), "KSPGetConvergedReason");
  petsc_check(KSPGetIterationNumber(ksp_, &iterations), "KSPGetIterationNumber");
  last_iterations_ = static_cast<int>(iterations);
  if (reason < 0)  // the same on every rank: KSP's reason is collective
    throw Error("DistributedHeatFlow: conjugate gradients did not reach 1e-12 (PETSc reason " + std::to_string(reason) + ", " +
                std::to_string(iterations) + " iterations); try the AMG preconditioner or a smaller dt");
  Eigen::VectorXd next = from_petsc(x_, n);
  // Each surface's heat back exactly (core/heat_flow.cpp says why), by a constant shift.
  std::vector<double> change(surface_area_.size(), 0.0);
  for (Eigen::Index i = 0; i < n; ++i)
    if (op_.mu[i] > 0) change[static_cast<std::size_t>(op_.surface_of[static_cast<std::size_t>(i)])] += op_.mu[i] * (next[i] - u[i]);
  all_reduce(Ranks(op_.comm), change, MPI_SUM);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto c = static_cast<std::size_t>(op_.surface_of[static_cast<std::size_t>(i)]);
    if (surface_area_[c] > 0) next[i] -= change[c] / surface_area_[c];
  }
  // Zero-area rows: u_i' (1 - theta dt L_ii) = u_i + dt ((1 - theta) (L u)_i + theta sum_{j != i} L_ij u_j'),
  // the u_j' with L_ij != 0 all of positive area (L_ij = w mu_j), hence known.
  if (op_.clamped > 0) {
    petsc_check(MatMult(op_.L, u_, work_), "MatMult");
    const Eigen::VectorXd Lu = from_petsc(work_, n);
    for (Eigen::Index i = 0; i < n; ++i)
      if (!(op_.mu[i] > 0)) next[i] = 0.0;
    to_petsc(next, x_);
    petsc_check(MatMult(op_.L, x_, work_), "MatMult");
    const Eigen::VectorXd Lnext = from_petsc(work_, n);
    petsc_check(MatGetDiagonal(op_.L, work_), "MatGetDiagonal");
    const Eigen::VectorXd Lii = from_petsc(work_, n);
    for (Eigen::Index i = 0; i < n; ++i)
      if (!(op_.mu[i] > 0)) next[i] = (u[i] + dt_ * ((1 - theta_) * Lu[i] + theta_ * Lnext[i])) / (1 - theta_ * dt_ * Lii[i]);
  }
  return next;
}

Eigen::VectorXd DistributedHeatFlow::advance(const Eigen::VectorXd& u0, int steps) const {
  if (steps < 0) throw Error("DistributedHeatFlow::advance: steps must be >= 0");
  Eigen::VectorXd u = u0;
  for (int s = 0; s < steps; ++s) u = step(u);
  return u;
}

}  // namespace digilap::mpi
