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

#include "digilap/contour.hpp"
#include "digilap/core/operator.hpp"
#include "digilap/measures.hpp"

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <cstddef>
#include <vector>

namespace digilap {

/// Distance between elements: along the contour (the paper's choice; only elements of the same
/// contour interact) or straight-line (BSW08's and DGtal's choice; any two elements interact).
enum class DistanceMode { Geodesic, Euclidean };
/// Where the elements sit: on the pointels (the paper's vertices, measure mu(v)) or on the
/// linel midpoints (DGtal's "dual" operator, measure mu(l)).
enum class Placement { Pointels, Linels };

struct HeatLaplacianOptions {
  /// Heat time. 0 (the default) means t = c_t h^(2/3) l^(4/3), l the length scale.
  double t = 0.0;
  /// Constant of the default heat time, unit-free (docs/accuracy.md: 0.1).
  double c_t = 0.1;
  /// The length scale l of the default heat time; 0 (the default) takes the measures' one
  /// (what the normals measured on the set, length_scale.hpp). Give 1 for the former
  /// t = c_t h^(2/3) in the set's units.
  double length_scale = 0.0;
  /// Geodesic distance with a measured l: each contour gets its own heat time
  /// c_t h^(2/3) l_c^(4/3) from its own length scale l_c (Measures::contour_length_scales), since
  /// contours do not interact: a speck does not shrink the time of a large contour, nor does a
  /// large contour's time swamp a small one. false: one t for all, from the set's l. Contours
  /// that interact (Euclidean distance) always share one t; a given t or l is used for all.
  bool per_contour_time = true;
  /// Surfaces only: kernel weights between different connected surfaces (the ambient coupling
  /// of earlier releases, one heat time for all). Off (the default): a surface's operator does
  /// not join disconnected pieces; each surface has its own rows, heat time (as contours do,
  /// per_contour_time) and zero eigenvalue.
  bool couple_surfaces = false;
  /// Kernel cut at distance k * sqrt(t). k = 6 leaves under 1e-3 of the kernel's second moment
  /// outside (DGtal's K = 3 in its K sqrt(2t) convention is our k = 4.24).
  double k = 6.0;
  DistanceMode distance = DistanceMode::Geodesic;
  Placement placement = Placement::Pointels;
  /// Richardson extrapolation 2 L_{t/2} - L_t: cancels the O(t) bias of the heat kernel (which
  /// shrinks omega^2 to (1 - exp(-omega^2 t)) / t), so functions with large second derivatives
  /// gain accuracy (docs/accuracy.md). It loses the sign pattern (some off-diagonal entries are
  /// negative) and with it the guarantee that A is negative semidefinite: keep it off for heat
  /// flow and spectra.
  bool richardson = false;
  /// Also assemble the symmetric stiffness A = M L (needed by heat flow and spectra). Without
  /// it the operator takes half the memory (op.A stays empty): what matters at h = 1e-4.
  bool stiffness = true;
  /// Refuse to allocate the matrices if their estimated size exceeds this (bytes).
  double memory_limit_bytes = 8.0 * 1024 * 1024 * 1024;
};

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

/// The heat time actually used: options.t, or c_t h^(2/3) l^(4/3) when options.t == 0, with
/// l = options.length_scale, or the measures' length scale when that is 0. Throws
/// digilap::Error when neither gives l (measures built by hand: give t or length_scale).
double heat_time(double h, const HeatLaplacianOptions& options, const Measures& measures);
/// The same with the measured length scale given directly (0: none), for any dimension.
double heat_time(double h, const HeatLaplacianOptions& options, double measured_length_scale);
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

}  // namespace digilap
