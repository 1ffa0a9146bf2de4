// digilap — spectra of contours: the names of earlier releases and the closed curve's exact
// heat-kernel eigenvalues. The solvers themselves are written once for every dimension
// (core/spectrum.hpp).
#pragma once

#include "digilap/core/spectrum.hpp"
#include "digilap/curve/heat_laplacian.hpp"

#include <vector>

namespace digilap {
inline namespace curve {

/// smallest_eigenpairs_per_part for contours (the name of earlier releases).
inline std::vector<Spectrum> smallest_eigenpairs_per_contour(const ContourOperator& op, const SpectrumOptions& options = {}) {
  return smallest_eigenpairs_per_part(op, options);
}

/// The heat-kernel operator's eigenvalues on a closed curve of length P with heat time t:
/// (1 - exp(-omega^2 t)) / t, omega = 2 pi m / P (SPEC §5). With t = 0: omega^2 exactly.
double heat_kernel_eigenvalue(int m, double P, double t);

}  // namespace curve
}  // namespace digilap
