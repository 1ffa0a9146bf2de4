// Internal: what a MatrixFreeLaplacian holds, behind its pointer (curve/matrix_free.hpp): the
// plan of the fast Gauss transform (boxes, bands, expansion tables, each row's window) and the
// products' scratch. The public class forwards to it.
#pragma once

#include "digilap/curve/matrix_free.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace digilap {
inline namespace curve {

struct MatrixFreeLaplacian::Plan {
  // The public class's API (curve/matrix_free.hpp documents it).
  Plan(const ContourSet& contours, const Measures& measures, const HeatLaplacianOptions& options, double epsilon);

  Eigen::Index rows() const { return mass_.size(); }
  Eigen::Index cols() const { return mass_.size(); }
  double t() const { return t_; }
  std::vector<double> contour_t() const;
  double length_scale() const { return length_scale_; }
  double cut() const { return cut_; }
  int order() const { return order_; }
  int band_order() const { return band_order_; }
  bool wide_kernels() const { return wide_kernels_; }
  double direct_share() const;
  const Eigen::VectorXd& mass() const { return mass_; }
  const Eigen::VectorXd& diagonal() const { return diagonal_; }
  const std::vector<Eigen::Index>& row_offset() const { return offset_; }
  const Eigen::MatrixX2d& positions() const { return positions_; }
  const Eigen::VectorXd& arclength() const { return s_; }
  bool contour_is_connected(std::size_t c) const;
  std::vector<double> contour_lengths() const;

  void apply(const double* x, double* y) const;
  Eigen::VectorXd operator*(const Eigen::VectorXd& x) const;
  void apply_contour(std::size_t c, const double* x, double* y) const;
  void apply_contour_block(std::size_t c, const Eigen::MatrixXd& x, Eigen::MatrixXd& y) const;
  Eigen::VectorXd apply_stiffness(const Eigen::VectorXd& x) const;


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

}  // namespace curve
}  // namespace digilap
