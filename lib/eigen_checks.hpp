// Internal: what both eigen-solvers (factorized and matrix-free) check and report alike.
#pragma once

#include "digilap/error.hpp"

#include <Eigen/Core>
#include <Spectra/Util/CompInfo.h>

#include <sstream>
#include <string>

namespace digilap::detail {

/// count in [1, N - 1] and every mass > 0 (M must be definite), or digilap::Error.
inline void check_eigen_request(const Eigen::VectorXd& mass, int count) {
  const Eigen::Index n = mass.size();
  if (count < 1 || count > n - 1)
    throw Error("smallest_eigenpairs: count must be in [1, " + std::to_string(n - 1) + "], got " + std::to_string(count));
  for (Eigen::Index i = 0; i < n; ++i)
    if (!(mass[i] > 0))
      throw Error("smallest_eigenpairs: the mass of row " + std::to_string(i) +
                  " is not > 0 (a zero measure: the element's II normal is orthogonal to it); "
                  "M must be definite: use pointels or a smaller k_R");
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
