// digilap — heat diffusion du/dtau = L u across MPI ranks (issue 24): the one-machine HeatFlow's
// scheme (core/heat_flow.hpp) on the distributed pair (A, M) of surface_operator.hpp, each
// step's system M - theta dt A solved by PETSc's conjugate gradients (KSPCG) with a Jacobi or
// a hypre BoomerAMG preconditioner. As on one machine: the heat sum_i mu_i u_i of each surface
// is put back exactly after each solve, and surfels of zero area are stepped with their own row
// of L once the others are known.
#pragma once

#include "digilap/core/heat_flow.hpp"
#include "digilap/mpi/surface_operator.hpp"

#include <petscksp.h>

#include <Eigen/Core>

namespace digilap::mpi {

enum class DistributedPreconditioner {
  Jacobi,  ///< M dominates M - theta dt A for the steps a flow takes (dt A / M ~ dt / t): few iterations
  Amg,     ///< hypre BoomerAMG: for steps far longer than t, where Jacobi's iterations grow
};

class DistributedHeatFlow {
public:
  /// Collective. Throws digilap::Error for dt not > 0 and finite.
  DistributedHeatFlow(const DistributedSurfaceOperator& op, double dt, TimeScheme scheme = TimeScheme::CrankNicolson,
                      DistributedPreconditioner preconditioner = DistributedPreconditioner::Jacobi);
  DistributedHeatFlow(const DistributedHeatFlow&) = delete;
  DistributedHeatFlow& operator=(const DistributedHeatFlow&) = delete;
  ~DistributedHeatFlow();

  double dt() const { return dt_; }
  /// CG iterations of the last step.
  int last_iterations() const { return last_iterations_; }
  /// One step (collective): u holds this rank's rows (row_begin ... row_end).
  Eigen::VectorXd step(const Eigen::VectorXd& u) const;
  /// `steps` steps from u0 (collective).
  Eigen::VectorXd advance(const Eigen::VectorXd& u0, int steps) const;

private:
  const DistributedSurfaceOperator& op_;
  double dt_;
  double theta_;
  Mat system_ = nullptr;  // M - theta dt A, 1 on the diagonal of zero-area rows
  KSP ksp_ = nullptr;
  Vec u_ = nullptr, b_ = nullptr, x_ = nullptr, work_ = nullptr;
  std::vector<double> surface_area_;  // sum of mu per surface, all ranks
  mutable int last_iterations_ = 0;
};

}  // namespace digilap::mpi
