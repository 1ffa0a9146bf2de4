// digilap — the heat Laplacian applied without storing it: a 1D fast Gauss transform along the
// arclength (geodesic mode), O(N p) per product instead of O(nnz) = O(N h^(-2/3)).
//
// In geodesic mode, (L g)_i = c [ (G * (mu g))_i - g_i (G * mu)_i ], a Gaussian convolution
// of mu g over the sorted positions S_j along each (periodic) contour, truncated at k sqrt(t)
// exactly as the explicit matrix is (the same window of neighbours, element for element). The
// convolution splits each window into whole boxes of width <= sqrt(t), which every target of
// a box sees (Hermite expansions translated to a Taylor expansion about the box), and its two
// ends, where the windows of the box's targets differ (a series in the product of the target's
// and the source's offsets, after the Gaussian is factored about the end's centre: ~6 terms,
// over one box; the source or two a window reaches past that box are added term by term).
// Orders are the smallest that meet the error bound epsilon (default 1e-10, relative to the
// operator's scale max|L_ii| max|g|). Contours whose window covers half of them are summed
// directly.
#pragma once

#include "digilap/curve/heat_laplacian.hpp"
#include "digilap/curve/spectrum.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace digilap {
inline namespace curve {

class MatrixFreeLaplacian {
public:
  /// Geodesic distance only (throws digilap::Error for Euclidean, Richardson, or epsilon not
  /// in (0, 1)); placement, t, c_t and k as for heat_laplacian().
  MatrixFreeLaplacian(const ContourSet& contours, const Measures& measures, const HeatLaplacianOptions& options = {},
                      double epsilon = 1e-10);

  Eigen::Index rows() const { return mass_.size(); }
  Eigen::Index cols() const { return mass_.size(); }
  /// Heat time: the contour with the most rows' when each contour has its own (contour_t()).
  double t() const { return t_; }
  /// Heat time of each contour (HeatLaplacianOptions::per_contour_time), as the explicit operator's.
  std::vector<double> contour_t() const;
  /// The length scale l behind the default t (0 when t was given).
  double length_scale() const { return length_scale_; }
  double cut() const { return cut_; }
  /// Hermite expansion order used for whole boxes.
  int order() const { return order_; }
  /// Largest series order used at the window ends (0 when every contour is summed directly).
  int band_order() const { return band_order_; }
  /// Whether products run the AVX2 + FMA build of their loops (x86-64 CPUs that have both,
  /// unless the environment sets DIGILAP_PLAIN_KERNELS=1); results agree with the plain build
  /// to about 1e-14 of the operator's scale.
  bool wide_kernels() const { return wide_kernels_; }
  /// Share of the rows whose window is summed term by term (small contours, degenerate boxes).
  double direct_share() const;
  const Eigen::VectorXd& mass() const { return mass_; }
  /// The diagonal of L (to the same accuracy).
  const Eigen::VectorXd& diagonal() const { return diagonal_; }
  const std::vector<Eigen::Index>& row_offset() const { return offset_; }
  const Eigen::MatrixX2d& positions() const { return positions_; }
  /// Arclength coordinate S_i of each row along its contour, in [0, length of the contour).
  const Eigen::VectorXd& arclength() const { return s_; }
  /// Whether every element of contour c interacts with the next one (the cut reaches it):
  /// the contour's block is then one connected component, with the constants as its kernel.
  bool contour_is_connected(std::size_t c) const;
  /// Length P of each contour (the period of its arclength coordinate).
  std::vector<double> contour_lengths() const;

  /// y = L x (x and y of size rows(), not aliased). Parallel with OpenMP inside; do not call
  /// it on the same operator from several threads at once (it reuses scratch buffers).
  void apply(const double* x, double* y) const;
  Eigen::VectorXd operator*(const Eigen::VectorXd& x) const;
  /// y = L_c x for the block of contour c alone (x and y of its n_c rows, not aliased): the
  /// operator is block-diagonal by contour. Same threading caveat as apply().
  void apply_contour(std::size_t c, const double* x, double* y) const;
  /// Y = L_c X column by column, for an n_c x b block: the columns in parallel, each product
  /// on one thread with scratch of its own (with b >= the thread count, this scales better
  /// than the products one after another, each parallel inside). The same result, bit for
  /// bit, as apply_contour() on each column. Throws digilap::Error for a block whose row
  /// count is not n_c or a contour that does not exist. Same threading caveat as apply().
  void apply_contour_block(std::size_t c, const Eigen::MatrixXd& x, Eigen::MatrixXd& y) const;
  /// y = A x = M L x.
  Eigen::VectorXd apply_stiffness(const Eigen::VectorXd& x) const;

private:
  // One end of the windows of the targets of a box: the sources lo..hi (indices unwrapped
  // around the contour), expanded about their centre (see gauss_transform).
  struct Band {
    Eigen::Index lo = 0, hi = -1;
    std::size_t data = 0;  // its first entry in band_two_beta_ / band_weight_
  };
  struct TargetBox {
    bool direct = false;                     // summed term by term (degenerate geometry)
    Eigen::Index core_lo = 0, core_hi = -1;  // the whole source boxes every target sees
    Eigen::Index core_first_box = 0, core_last_box = -1;  // their boxes, when the core does not wrap
    Band forward, backward;                  // the window ends beyond them
    int band_order = 0;                      // terms of the bands' series
    std::size_t corrections_begin = 0, corrections_end = 0;  // its entries in correction_
  };
  // A source a target's window reaches beyond its bands (weight > 0), or a source of the core
  // it does not reach (weight < 0): see plan_contour.
  struct Correction {
    Eigen::Index target;  // offset in its box
    Eigen::Index source;  // element of the contour
    double weight;        // +- exp(-(S_source - S_target)^2 / delta^2)
  };
  struct Contour {
    Eigen::Index offset = 0, n = 0;
    double P = 0;
    // Its heat time and what follows from it (contours may have their own: contour_t()).
    double t = 0, cut = 0, delta = 0, box = 0, scale = 0;
    bool direct = false;  // window >= half the contour, or tiny: direct sums
    Eigen::Index boxes = 0;
    std::vector<Eigen::Index> box_start;  // first element of each box (size boxes + 1)
    std::vector<Eigen::Index> box_of;     // box of each element
    std::vector<TargetBox> plan;          // per target box
  };
  // The geometric part of the transform, fixed by the positions: per target box its core and
  // its two bands, with their expansion weights; per target its offset and band factors.
  void plan_contour(Contour& ct, double epsilon);
  // Scratch of one product: box moments (boxes x order), mu x and its transform.
  struct Scratch {
    std::vector<double> box_moments;
    Eigen::VectorXd weighted, transformed;
  };
  // (G * f)_i over the window of each row i (j = i included), into out, with f = mu x (into
  // scratch.weighted) and y_i = c (out_i - x_i (G * mu)_i), box by box while out is in cache;
  // without x, f = mu and no y. One parallel region per contour.
  void gauss_transform(const double* x, double* out, double* y, Scratch& scratch) const;
  // The same for one contour, x, f, out and y pointing at its first row.
  void contour_transform(const Contour& ct, const double* xc, double* fc, double* oc, std::vector<double>& box_moments,
                         double* yc) const;
  // apply_contour() with the given scratch.
  void apply_contour_with(std::size_t c, const double* x, double* y, Scratch& scratch) const;
  void direct_sums(const Contour& ct, Eigen::Index i0, Eigen::Index i1, const double* fc, double* oc) const;
  // contour_transform's work per source box and per target box, built twice: plain and, on
  // x86-64, for AVX2 + FMA (wide), chosen at construction (lib/matrix_free_kernels.inc).
  struct KernelArgs;
  struct BoxScratch;
  void box_moments_plain(const KernelArgs& a, Eigen::Index k) const;
  void target_box_plain(const KernelArgs& a, Eigen::Index kt, BoxScratch& scratch) const;
  void box_moments_wide(const KernelArgs& a, Eigen::Index k) const;
  void target_box_wide(const KernelArgs& a, Eigen::Index kt, BoxScratch& scratch) const;
  bool wide_kernels_ = false;

  std::vector<Contour> contours_;
  std::vector<Eigen::Index> offset_;
  Eigen::VectorXd mass_, s_, diagonal_, transform_of_mass_;
  Eigen::MatrixX2d positions_;
  std::vector<Eigen::Index> back_, fwd_;  // the geodesic window of each row
  double t_ = 0, length_scale_ = 0, cut_ = 0, delta_ = 0, box_ = 0, scale_ = 0;
  int order_ = 0, band_order_ = 0;
  Eigen::Index reach_ = 0;
  std::vector<double> translation_;  // Hermite to Taylor matrices T_d, |d| <= reach_ (translation_matrix)
  std::vector<double> band_two_beta_, band_weight_;  // per band entry: 2 beta_j, w_j
  // Per row, the row of each band's moments its window reads (see add_bands): fixed by the
  // plan, so read rather than recomputed from the windows at each product.
  struct BandRows {
    std::int32_t forward = 0, backward = 0;
  };
  std::vector<BandRows> band_rows_;
  std::vector<Correction> correction_;
  Eigen::VectorXd alpha_, tau_forward_, tau_backward_;
  // Scratch reused by every product (apply, apply_contour): products on one operator are
  // therefore not thread-safe (each runs in parallel inside).
  mutable Scratch scratch_;
};

/// The `count` smallest eigenpairs of -A x = lambda M x through the matrix-free operator,
/// contour by contour (the operator is block-diagonal by contour), merged so that repeated
/// eigenvalues of identical contours all count; contours of up to 400 rows are solved densely.
/// On each larger contour, on C = M^(1/2) (-L_c) M^(-1/2): first block LOBPCG preconditioned by the 1D Laplacian along the
/// arclength (its heat-operator form D2 (I + t D2)^-1, a cyclic tridiagonal solve): about 10
/// iterations whatever h. If that has not converged after min(max_iterations, 300) iterations
/// (or N is tiny), Lanczos (Spectra) on c I - C, c = 2 max|L_ii| (Gershgorin), with
/// max_iterations restarts and `subspace` vectors. Converged when every wanted residual
/// |C y - lambda y| <= tolerance * c (LOBPCG), or Spectra's Ritz-value test at `tolerance`.
/// No factorization of L: memory O(N count). Eigenvectors are M-orthonormal; `iterations`
/// and `operations` report the method that answered (summed over contours); eigenvectors have
/// a fixed sign (largest entry positive), and the result does not depend on the number of
/// threads. Throws digilap::Error for a zero mass, no convergence, or a contour whose
/// elements do not interact (a cut below the spacing of consecutive elements).
Spectrum smallest_eigenpairs(const MatrixFreeLaplacian& op, const SpectrumOptions& options = {});

/// The spectrum of each contour on its own: element c holds the min(count, n_c) smallest
/// eigenpairs of contour c, on its n_c rows.
std::vector<Spectrum> smallest_eigenpairs_per_contour(const MatrixFreeLaplacian& op, const SpectrumOptions& options = {});

/// One implicit Euler heat step (M - dt A) u' = M u solved by Eigen's ConjugateGradient on the
/// matrix-free operator (Jacobi preconditioner), to relative residual `tolerance`.
/// Returns u'; throws digilap::Error if CG does not converge.
Eigen::VectorXd heat_step_cg(const MatrixFreeLaplacian& op, const Eigen::VectorXd& u, double dt,
                             double tolerance = 1e-10, int* iterations = nullptr);

}  // namespace curve
}  // namespace digilap
