// Internal: the one rule for elements of zero mass, shared by spectra and heat flow (see
// core/operator.hpp): they are off the support of mu, and take their values from their row of L.
#pragma once

#include "digilap/core/operator.hpp"

#include <vector>

namespace digilap::detail {

/// Throws digilap::Error (message starting with `who`) unless every row of `massless` reaches
/// mass through its row of L, i.e. has a neighbour with mass within the kernel's cut (L_ii < 0).
void check_massless_reach_mass(const HeatOperator& op, const std::vector<Eigen::Index>& massless, const char* who);

}  // namespace digilap::detail
