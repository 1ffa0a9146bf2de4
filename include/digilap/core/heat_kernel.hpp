// digilap — the heat kernel's parameters, written once for every dimension (core): the
// options of the heat-kernel Laplacian (curve/heat_laplacian.hpp, surface/heat_laplacian.hpp)
// and the default heat time t = c_t h^(2/3) l^(4/3) (SPEC §4, §7).
#pragma once

namespace digilap {

/// Curves only (surfaces use the Euclidean distance). Distance between elements: along the contour (the paper's choice; only elements of the same
/// contour interact) or straight-line (BSW08's and DGtal's choice; any two elements interact).
enum class DistanceMode { Geodesic, Euclidean };
/// Curves only. Where the elements sit: on the pointels (the paper's vertices, measure mu(v)) or on the
/// linel midpoints (DGtal's "dual" operator, measure mu(l)).
enum class Placement { Pointels, Linels };
/// Surfaces only. The kernel's distance between two surfels (docs/accuracy.md, "Why the torus
/// stalls"): the chord |x_i - x_j| (SPEC §7), or the intrinsic one, which follows the surface
/// with the normals n: the chord in the mean tangent plane, m = (n_i + n_j) / |n_i + n_j|, plus
/// the second-order geodesic term,
///   d^2 = |x_j - x_i|^2 - <x_j - x_i, m>^2 + <x_j - x_i, n_j - n_i>^2 / 12,
/// (the tangent part removes the staircase's jitter of the centres along the normal, the last
/// term the chord's shortening on a curved surface), each weight times (1 + g_i)(1 + g_j),
/// g = t K / 2 with K the Gaussian curvature estimated from the kernel-weighted pair moments
/// of positions and normals (it takes out the geodesic Gaussian's own -K t bias). Pairs
/// whose normals are more than 90 degrees apart keep the chord and stay out of K.
enum class SurfaceKernel { Chord, Intrinsic };

struct HeatLaplacianOptions {
  /// Heat time. 0 (the default) means t = c_t h^(2/3) l^(4/3), l the length scale.
  double t = 0.0;
  /// Constant of the default heat time, unit-free (docs/accuracy.md: 0.1).
  double c_t = 0.1;
  /// The length scale l of the default heat time; 0 (the default) takes the measures' one
  /// (what the normals measured on the set, curve/length_scale.hpp, surface/length_scale.hpp). Give 1 for the former
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
  /// Surfaces only: the kernel's distance (SurfaceKernel). Intrinsic needs the measures' normals.
  SurfaceKernel surface_kernel = SurfaceKernel::Intrinsic;
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
  /// Matrix-free surface operators only: keep the kernel's weights when all of them take at
  /// most this (bytes; 0: never), so that products stop recomputing distances and Gaussians
  /// (the same bits). Each pair is kept once, about 8 bytes a nonzero of L: real labels fit
  /// (JHU 1 mm's largest tract: 8 MB) and their spectra, many products on small surfaces, gain;
  /// large smooth surfaces (a torus at h = 0.025, about 1,000 neighbours a row) stay in O(N)
  /// memory. Never more than a quarter of memory_limit_bytes.
  double stored_weights_bytes = 32.0 * 1024 * 1024;
};

/// The heat time actually used, in any dimension: options.t, or c_t h^(2/3) l^(4/3) when
/// options.t == 0, with l = options.length_scale, or `measured_length_scale` (the measures' l)
/// when that is 0. Throws digilap::Error when neither gives l (0: none; measures built by hand:
/// give t or length_scale), or for c_t not > 0 and finite.
double heat_time(double h, const HeatLaplacianOptions& options, double measured_length_scale);

}  // namespace digilap
