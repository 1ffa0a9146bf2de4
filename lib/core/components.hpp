// Internal: the connected components of an operator's graph (rows i and j joined when the
// entry (i, j) is non-zero). The kernel of -A is spanned by one constant vector per component,
// so heat is conserved per component and the spectrum is the union of the components' spectra.
// Geodesic operators have one component per contour (unless t is so small that elements stop
// interacting); Euclidean ones join the contours that come near each other.
#pragma once

#include "digilap/core/operator.hpp"

#include <vector>

namespace digilap::detail {

struct Components {
  std::vector<int> of_row;                      ///< component of each row
  std::vector<std::vector<Eigen::Index>> rows;  ///< rows of each component, ascending; components
                                                ///< numbered in the order of their first row
};

/// Components of the graph of a square sparse matrix with a symmetric pattern.
Components connected_components(const SparseMatrix& A);

}  // namespace digilap::detail
