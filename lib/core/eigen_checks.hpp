// Internal: what both eigen-solvers (factorized and matrix-free) check and report alike.
#pragma once

#include "digilap/core/error.hpp"

#include <Eigen/Core>
#include <Spectra/Util/CompInfo.h>

#include <cmath>
#include <sstream>
#include <string>

namespace digilap::detail {

/// Every mass a number >= 0 (mu = 0 is an element off the support, see core/operator.hpp), or
/// digilap::Error naming the row.
inline void check_masses(const Eigen::VectorXd& mass, const char* who = "smallest_eigenpairs") {
  for (Eigen::Index i = 0; i < mass.size(); ++i)
    if (!(mass[i] >= 0) || !std::isfinite(mass[i]))
      throw Error(std::string(who) + ": the mass of row " + std::to_string(i) + " is " + std::to_string(mass[i]) +
                  ": masses must be finite and >= 0");
}

/// A tolerance in [1e-14, 1) and at least one iteration, or digilap::Error (below 1e-14 the
/// residuals' rounding decides: the solver would run every iteration allowed and then fail).
inline void check_solver_options(double tolerance, int max_iterations) {
  if (!(tolerance >= 1e-14 && tolerance < 1)) {
    std::ostringstream msg;
    msg << "smallest_eigenpairs: tolerance must be in [1e-14, 1) (rounding bounds the residuals below), got " << tolerance;
    throw Error(msg.str());
  }
  if (max_iterations < 1)
    throw Error("smallest_eigenpairs: max_iterations must be >= 1, got " + std::to_string(max_iterations));
}

/// count in [1, n - 1] for a problem on n rows with mass, or digilap::Error.
inline void check_count(Eigen::Index n, Eigen::Index massless, int count) {
  if (count >= 1 && count <= n - 1) return;
  std::string msg = "smallest_eigenpairs: count must be in [1, " + std::to_string(n - 1) + "], got " + std::to_string(count);
  if (massless > 0) msg += " (" + std::to_string(massless) + " rows of zero mass are off the support and add no eigenpair)";
  throw Error(msg);
}

/// count in [1, N - 1] and every mass > 0 (M must be definite), or digilap::Error: for the
/// solvers that do not restrict the problem to the support of mu (the matrix-free one).
inline void check_eigen_request(const Eigen::VectorXd& mass, int count) {
  check_count(mass.size(), 0, count);
  for (Eigen::Index i = 0; i < mass.size(); ++i)
    if (!(mass[i] > 0))
      throw Error("smallest_eigenpairs: the mass of row " + std::to_string(i) +
                  " is not > 0 (a zero measure: the element's II normal is orthogonal to it); the matrix-free solver "
                  "needs every mass > 0: use the explicit operator (smallest_eigenpairs(op)), which solves on the "
                  "support of mu, or pointels, or a smaller k_R");
}

/// Spectra's status turned into digilap::Error, with the numbers and what to try.
template <class Solver>
void require_converged(const Solver& eigs, Eigen::Index converged, int count, int ncv) {
  if (eigs.info() == Spectra::CompInfo::Successful && converged >= count) return;
  std::ostringstream msg;
  msg << "smallest_eigenpairs: Spectra did not converge (" << converged << " of " << count << " eigenpairs after "
      << eigs.num_iterations() << " restarts); raise max_iterations or the subspace size (" << ncv << ")";
  throw Error(msg.str());
}

}  // namespace digilap::detail
