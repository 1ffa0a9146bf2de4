// digilap — the heat-kernel Laplacian L_h of digital contours as a sparse matrix (SPEC §4).
//
//   (L g)_i = 1 / (t sqrt(4 pi t)) * sum_{j != i, d(i,j) <= k sqrt(t)} exp(-d(i,j)^2 / (4t)) (g_j - g_i) mu_j
//
// L approximates +d^2/ds^2 (negative semidefinite, the sign of libigl's cotmatrix): its
// off-diagonal entries are >= 0 and its rows sum to 0. With M = diag(mu), A = M L is symmetric
// negative semidefinite; heat flow and eigen-analysis use the pair (A, M).
//
// Rows are elements in contour order, contour after contour: element r of the matrix is
// position `r - row_offset[c]` of contour c, for the c with row_offset[c] <= r < row_offset[c+1].
// With Placement::Pointels element i of a contour is its vertex v_i (pointel `pointels[i]`), with
// Placement::Linels it is the midpoint of linel l_i.
#pragma once

#include "digilap/core/heat_kernel.hpp"
#include "digilap/core/operator.hpp"
#include "digilap/curve/contour.hpp"
#include "digilap/curve/measures.hpp"

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <cstddef>
#include <vector>

namespace digilap {
inline namespace curve {

/// An operator on the elements of contours (a HeatOperator of dimension 1 whose parts are the
/// contours), with everything needed to use and interpret it.
struct ContourOperator : HeatOperator {
  Eigen::MatrixX2d positions;   ///< element positions
  Eigen::VectorXd arclength;    ///< arclength coordinate of each element along its contour
  std::vector<double> contour_length;    ///< estimated length P of each contour
  Placement placement = Placement::Pointels;

  /// Contour and position within it of a row.
  std::pair<std::size_t, std::size_t> element(Eigen::Index row) const;
};

/// The heat-kernel Laplacian of SPEC §4. Assembly: each row's neighbours come from a window
/// over the sorted arclengths (geodesic) or a uniform grid of cell k sqrt(t) (Euclidean), the
/// rows are counted, the compressed arrays allocated once and filled in parallel; the matrix is
/// bitwise identical for any number of OpenMP threads.
/// Throws digilap::Error for t, c_t or k not > 0 and finite, no length scale for the default t
/// (see heat_time), mismatched measures, or an
/// estimated size above options.memory_limit_bytes.
ContourOperator heat_laplacian(const ContourSet& contours, const Measures& measures,
                               const HeatLaplacianOptions& options = {});

/// The heat time of contours (core/heat_kernel.hpp) with the measures' length scale: throws
/// digilap::Error when neither options nor measures give l (measures built by hand: give t or
/// length_scale).
double heat_time(double h, const HeatLaplacianOptions& options, const Measures& measures);
/// The heat time of each of `contours` contours: heat_time() for all, or per contour from
/// measures.contour_length_scales when options.per_contour_time applies (geodesic distance, t and
/// length_scale not given, the measures carrying one l_c per contour).
std::vector<double> contour_heat_times(double h, const HeatLaplacianOptions& options, const Measures& measures,
                                       std::size_t contours);

/// Which edge lengths the DEC baseline uses.
enum class DecLengths { Naive, Corrected };

/// Baseline: the DEC (cotan-like) Laplacian of each closed contour on its pointels,
///   (L g)_i = ((g_{i+1} - g_i) / len_i + (g_{i-1} - g_i) / len_{i-1}) / ((len_{i-1} + len_i) / 2),
/// with len_i = h (Naive) or mu(l_i) (Corrected). The paper's point (its Fig. 1 and 5): this does
/// not converge on digital curves. Corrected lengths of exactly 0 are raised to 1e-6 h (it
/// divides by them) and counted in `clamped_lengths`.
ContourOperator dec_laplacian(const ContourSet& contours, const Measures& measures, DecLengths lengths,
                              std::size_t* clamped_lengths = nullptr);

}  // namespace curve
}  // namespace digilap
