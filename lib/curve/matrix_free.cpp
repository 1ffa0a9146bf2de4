#include "digilap/curve/matrix_free.hpp"
#include "digilap/core/constants.hpp"

#include "digilap/core/error.hpp"
#include "core/eigen_checks.hpp"
#include "elements.hpp"
#include "cyclic_tridiagonal.hpp"
#include "core/lobpcg.hpp"
#include "core/spectrum_parts.hpp"

#include <Eigen/IterativeLinearSolvers>
#include <Spectra/SymEigsSolver.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <numeric>
#include <sstream>
#include <tuple>
#include <type_traits>

namespace digilap {
inline namespace curve {

namespace {

// Smallest order p whose Hermite truncation error, relative to the sources' total weight,
// is below epsilon. With sources within rho * delta of the box centre, Cramer's inequality
// |h_n(u)| <= K 2^(n/2) sqrt(n!) (K < 1.09) bounds the tail by
// K (sqrt(2) rho)^p / sqrt(p!) / (1 - sqrt(2) rho).
int hermite_order(double rho, double epsilon) {
  const double q = std::sqrt(2.0) * rho;
  double term = 1.0;  // q^p / sqrt(p!)
  for (int p = 1; p < 63; ++p) {
    term *= q / std::sqrt(static_cast<double>(p));
    if (1.09 * term / (1 - q) <= epsilon) return p;
  }
  return 63;  // the moment buffers hold 64
}

// Smallest order q whose remainder of the series sum_n x^n / n! (x = 2 |alpha beta| at the
// window ends), times the bound `gaussian` on the factored Gaussian, is below epsilon:
// gaussian e^x x^q / q! / (1 - x / (q + 1)). Returns kMaxBandOrder + 1 when none is.
constexpr int kMaxBandOrder = 24;
constexpr int kMaxBandPairs = (kMaxBandOrder + 1) / 2;
constexpr int kMaxHalfColumns = 32;  // half_columns(63)
// Two doubles as one vector (GCC and Clang's vector extension: SSE2 on x86-64, NEON on arm64,
// plain pairs elsewhere). The band loops use it where the compiler would not vectorize.
using Pair = double __attribute__((vector_size(16)));
using Quad = double __attribute__((vector_size(32)));

// The kernels are also built for AVX2 + FMA (x86-64 with GCC), used when the CPU has both;
// DIGILAP_PLAIN_KERNELS=1 in the environment keeps the plain ones (to compare the two).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define DIGILAP_WIDE_KERNELS 1
#else
#define DIGILAP_WIDE_KERNELS 0
#endif
bool cpu_takes_wide_kernels() {
#if DIGILAP_WIDE_KERNELS
  const char* plain = std::getenv("DIGILAP_PLAIN_KERNELS");
  if (plain != nullptr && plain[0] != '\0' && plain[0] != '0') return false;
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
  return false;
#endif
}
constexpr int kLanes = 8;  // sources whose power chains run side by side
int band_series_order(double x, double gaussian, double epsilon) {
  double term = gaussian * std::exp(x);  // gaussian e^x x^q / q!
  for (int q = 1; q <= kMaxBandOrder; ++q) {
    term *= x / q;
    if (x < q + 1 && term / (1 - x / (q + 1)) <= epsilon) return q;
  }
  return kMaxBandOrder + 1;
}

// h_0 .. h_{count-1} at u: h_n(u) = H_n(u) exp(-u^2).
void hermite_functions(double u, int count, double* h) {
  h[0] = std::exp(-u * u);
  if (count > 1) h[1] = 2 * u * h[0];
  for (int q = 1; q + 1 < count; ++q) h[q + 1] = 2 * u * h[q] - 2 * q * h[q - 1];
}

// T[q][column(m)] = (-1)^m / m! h_{q+m}(u), q, m < p: the Hermite expansion (moments A_q) of a
// box at offset u (units of delta) translated to Taylor coefficients B_m = sum_q A_q T[q][m]
// about another box's centre, since d/du h_n = -h_{n+1}. Columns hold the even m, then the odd
// ones: boxes at -u and u then share one matrix, as h_n(-u) = (-1)^n h_n(u). Each half is
// padded with zeros to a multiple of 4 columns (whole vectors, no scalar tails).
inline int half_columns(int p) { return ((p + 1) / 2 + 3) / 4 * 4; }
inline int taylor_columns(int p) { return 2 * half_columns(p); }
inline int taylor_column(int m, int p) { return m % 2 == 0 ? m / 2 : half_columns(p) + m / 2; }
void translation_matrix(double u, int p, double* T) {
  const int columns = taylor_columns(p);
  std::fill_n(T, static_cast<std::size_t>(p) * columns, 0.0);
  double h[128];
  hermite_functions(u, 2 * p - 1, h);
  double factor = 1.0;
  for (int m = 0; m < p; ++m) {
    for (int q = 0; q < p; ++q) T[q * columns + taylor_column(m, p)] = factor * h[q + m];
    factor *= -1.0 / (m + 1);
  }
}

}  // namespace

MatrixFreeLaplacian::MatrixFreeLaplacian(const ContourSet& contours, const Measures& measures,
                                         const HeatLaplacianOptions& options, double epsilon) {
  if (options.distance != DistanceMode::Geodesic)
    throw Error("MatrixFreeLaplacian: only the geodesic distance is a convolution along the contour");
  if (options.richardson) throw Error("MatrixFreeLaplacian: Richardson extrapolation is not available matrix-free");
  if (!(epsilon > 0 && epsilon < 1)) {
    std::ostringstream msg;
    msg << "MatrixFreeLaplacian: epsilon must be in (0, 1), got " << epsilon;
    throw Error(msg.str());
  }
  require_positive("MatrixFreeLaplacian: k", options.k);
  wide_kernels_ = cpu_takes_wide_kernels();
  const detail::Elements e = detail::gather_elements(contours, measures, options.placement);
  // Each contour's heat time, as the explicit operator takes them; box, delta and the cut scale
  // with sqrt(t_c) together, so box / delta, the Hermite order and the table of whole-box
  // offsets below are the same for every contour.
  const std::vector<double> contour_t = contour_heat_times(contours.h, options, measures, e.offset.size() - 1);
  std::size_t largest = 0;
  for (std::size_t c = 0; c + 1 < e.offset.size(); ++c)
    if (e.offset[c + 1] - e.offset[c] > e.offset[largest + 1] - e.offset[largest]) largest = c;
  t_ = contour_t.empty() ? heat_time(contours.h, options, measures) : contour_t[largest];
  // The l behind t_ (that of the same contour when the times are per contour).
  const bool own_l = options.t == 0 && options.length_scale == 0 && options.per_contour_time && !contour_t.empty() &&
                     measures.contour_length_scales.size() == contour_t.size();
  length_scale_ = options.t != 0                ? 0.0
                  : options.length_scale != 0   ? options.length_scale
                  : own_l                       ? measures.contour_length_scales[largest]
                                                : measures.length_scale;
  auto geometry = [&](double t) {  // cut, delta, box, scale for heat time t
    const double cut = options.k * std::sqrt(t), delta = std::sqrt(4 * t);
    // Boxes of width <= delta / 2: sources and targets within a quarter of delta of their box
    // centre. At most a third of the cut, so that the two ends of a box's windows stay apart.
    return std::array<double, 4>{cut, delta, std::min(0.5 * delta, cut / 3), 1.0 / (t * std::sqrt(4 * kPi * t))};
  };
  std::tie(cut_, delta_, box_, scale_) = std::tuple_cat(geometry(t_));
  // The Hermite (whole boxes) and the Taylor (their sum at a target) truncations get a tenth
  // of the error budget each, the bands (window ends, the larger share of the work) half.
  order_ = hermite_order(0.5 * box_ / delta_, 0.1 * epsilon);

  mass_ = e.mu;
  s_ = e.s;
  positions_ = e.positions;
  offset_ = e.offset;
  const Eigen::Index n_all = mass_.size();
  // Which contours are summed directly: those whose window covers half of them, tiny ones, and
  // those with more boxes than elements (t so small that boxes would only be empty: the memory
  // of the plan would grow like P / sqrt(t) instead of N, and direct windows are short then).
  std::vector<bool> direct(offset_.size() - 1);
  Eigen::Index most_boxes = 0, planned_rows = 0, planned_boxes = 0;
  for (std::size_t c = 0; c + 1 < offset_.size(); ++c) {
    const Eigen::Index n = offset_[c + 1] - offset_[c];
    const auto [cut_c, delta_c, box_c, scale_c] = geometry(contour_t[c]);
    const double boxes = std::ceil(e.length[c] / box_c);  // a double: P / box may exceed any integer
    direct[c] = cut_c >= 0.5 * e.length[c] || n < 64 || boxes < 8 || boxes > static_cast<double>(n);
    if (direct[c]) continue;
    most_boxes = std::max(most_boxes, static_cast<Eigen::Index>(boxes));
    planned_rows += n;
    planned_boxes += static_cast<Eigen::Index>(boxes);
  }
  // Translations for the box offsets a core can have: within the cut, and within a contour.
  reach_ = std::min<Eigen::Index>(static_cast<Eigen::Index>(std::min(std::ceil(cut_ / box_), 1e15)) + 2, most_boxes);
  // Estimate before allocating: per row the windows, element arrays and band factors (about
  // 17 doubles; for a planned row 4 band entries of 2 doubles, its band rows, and at most one
  // correction of 3), per box its plan and moments.
  const double bytes = 8.0 * (18.0 * static_cast<double>(n_all) + 12.0 * static_cast<double>(planned_rows)) +
                       static_cast<double>(planned_boxes) * (sizeof(TargetBox) + 16.0 + 8.0 * order_) +
                       8.0 * static_cast<double>(2 * reach_ + 1) * order_ * taylor_columns(order_);
  if (bytes > options.memory_limit_bytes) {
    std::ostringstream msg;
    msg << "MatrixFreeLaplacian: the operator would take about " << bytes / 1e9 << " GB (" << n_all
        << " rows), above the memory limit of " << options.memory_limit_bytes / 1e9
        << " GB; raise memory_limit_bytes or use a coarser h";
    throw Error(msg.str());
  }
  // Translation matrices T_d[q][m] = (-1)^m / m! h_{q+m}(d box / delta), |d| <= reach_.
  translation_.resize(static_cast<std::size_t>(2 * reach_ + 1) * order_ * taylor_columns(order_));
  for (Eigen::Index d = -reach_; d <= reach_; ++d)
    translation_matrix(static_cast<double>(d) * box_ / delta_, order_,
                       &translation_[static_cast<std::size_t>(d + reach_) * order_ * taylor_columns(order_)]);
  back_.assign(static_cast<std::size_t>(n_all), 0);
  fwd_.assign(static_cast<std::size_t>(n_all), 0);
  alpha_ = tau_forward_ = tau_backward_ = Eigen::VectorXd::Zero(n_all);
  band_rows_.assign(static_cast<std::size_t>(n_all), BandRows{});
  for (std::size_t c = 0; c + 1 < offset_.size(); ++c) {
    Contour ct;
    ct.offset = offset_[c];
    ct.n = offset_[c + 1] - offset_[c];
    ct.P = e.length[c];
    ct.t = contour_t[c];
    std::tie(ct.cut, ct.delta, ct.box, ct.scale) = std::tuple_cat(geometry(ct.t));
    const double* s = s_.data() + ct.offset;
#pragma omp parallel for schedule(static)
    for (Eigen::Index i = 0; i < ct.n; ++i) {
      const detail::GeodesicWindow w = detail::geodesic_window(s, ct.n, i, ct.P, ct.cut);
      back_[ct.offset + i] = w.back;
      fwd_[ct.offset + i] = w.fwd;
    }
    ct.direct = direct[c];
    if (!ct.direct) {
      ct.boxes = static_cast<Eigen::Index>(std::ceil(ct.P / ct.box));
      plan_contour(ct, epsilon);
    }
    contours_.push_back(std::move(ct));
  }
  Eigen::VectorXd row_scale(n_all);  // c of each row's contour
  for (const Contour& ct : contours_) row_scale.segment(ct.offset, ct.n).setConstant(ct.scale);
  transform_of_mass_.resize(n_all);
  gauss_transform(nullptr, transform_of_mass_.data(), nullptr, scratch_);
  // L_ii = -c sum_{j != i} G(d_ij) mu_j; the transform includes j = i with G(0) = 1.
  diagonal_ = -row_scale.cwiseProduct(transform_of_mass_ - mass_);
}

double MatrixFreeLaplacian::direct_share() const {
  Eigen::Index direct = 0;
  for (const Contour& ct : contours_) {
    if (ct.direct) {
      direct += ct.n;
      continue;
    }
    for (std::size_t k = 0; k < ct.plan.size(); ++k)
      if (ct.plan[k].direct) direct += ct.box_start[k + 1] - ct.box_start[k];
  }
  return rows() > 0 ? static_cast<double>(direct) / static_cast<double>(rows()) : 0.0;
}

// The window of target i is the sources lo(i) = i - back_i .. hi(i) = i + fwd_i (unwrapped).
// For the targets i0..i1 of a box, whole source boxes (the core) are seen by all of them, up
// to the sources a window does not reach, subtracted term by term; the rest of each window
// lies in two bands: forward [first of a box B, hi(i)] and backward [lo(i), last of a box B'],
// B and B' about cut from the targets, plus the source or two a window reaches past them,
// added term by term (see the choice of B below). With E a band's centre, c the target box's centre, alpha = (s_i - c) / delta,
// beta = (s_j - E) / delta and D = (E - c) / delta:
//   exp(-(s_j - s_i)^2 / delta^2) = exp(-(D + beta)^2) exp(2 D alpha - alpha^2) exp(2 alpha beta),
// and exp(2 alpha beta) = sum_n (2 alpha beta)^n / n! converges fast (|2 alpha beta| <= 1/4).
// The first factor is a weight of the source, the second of the target: the band contributes
// tau_i sum_n alpha_i^n M_n(i), with M_n(i) the moments sum w_j (2 beta_j)^n / n! over the
// part of the band in i's window, a prefix (forward) or suffix (backward) sum.
void MatrixFreeLaplacian::plan_contour(Contour& ct, double epsilon) {
  const double* s = s_.data() + ct.offset;
  const Eigen::Index n = ct.n;
  ct.box_of.resize(static_cast<std::size_t>(n));
  ct.box_start.assign(static_cast<std::size_t>(ct.boxes + 1), n);
  for (Eigen::Index j = n - 1; j >= 0; --j) {
    const Eigen::Index k = std::clamp<Eigen::Index>(static_cast<Eigen::Index>(s[j] / ct.box), 0, ct.boxes - 1);
    ct.box_of[j] = k;
    ct.box_start[k] = j;
  }
  // Empty boxes start where the next non-empty one does.
  for (Eigen::Index k = ct.boxes - 1; k >= 0; --k) ct.box_start[k] = std::min(ct.box_start[k], ct.box_start[k + 1]);

  // Unwrapped indices u in [-n, 2n): element u mod n, its position shifted by a period.
  auto wraps = [n](Eigen::Index u) -> Eigen::Index { return u < 0 ? -1 : (u >= n ? 1 : 0); };
  auto position = [&](Eigen::Index u) { return s[u - wraps(u) * n] + static_cast<double>(wraps(u)) * ct.P; };
  auto box_first = [&](Eigen::Index u) { return ct.box_start[ct.box_of[u - wraps(u) * n]] + wraps(u) * n; };
  auto box_last = [&](Eigen::Index u) { return ct.box_start[ct.box_of[u - wraps(u) * n] + 1] - 1 + wraps(u) * n; };

  ct.plan.assign(static_cast<std::size_t>(ct.boxes), TargetBox{});
  for (Eigen::Index kt = 0; kt < ct.boxes; ++kt) {
    const Eigen::Index i0 = ct.box_start[kt], i1 = ct.box_start[kt + 1] - 1;
    if (i0 > i1) continue;
    TargetBox& tb = ct.plan[kt];
    const double centre = (kt + 0.5) * ct.box, delta = ct.delta;
    Eigen::Index lo_min = 2 * n, hi_max = -n, core_lo = -n, core_hi = 2 * n;
    double alpha_max = 0;
    for (Eigen::Index i = i0; i <= i1; ++i) {
      const Eigen::Index lo = i - back_[ct.offset + i], hi = i + fwd_[ct.offset + i];
      lo_min = std::min(lo_min, lo);
      hi_max = std::max(hi_max, hi);
      core_lo = std::max(core_lo, lo);
      core_hi = std::min(core_hi, hi);
      alpha_max = std::max(alpha_max, std::abs(s[i] - centre) / delta);
    }
    tb.direct = true;  // unless the split below is sound
    if (core_lo > core_hi || lo_min < -n || hi_max >= 2 * n) continue;
    if (box_last(core_lo) >= box_first(core_hi)) continue;  // the two ends overlap: no core in between
    // Bands one box long. The ends of the windows of a box's targets mostly lie in one box,
    // but the nearest or farthest often straddle into the next box by a source or two; a band
    // over both boxes would put each source in three bands instead of two. So the band is the
    // box holding the middle target's end, clipped to the ends; the few sources a window
    // reaches beyond it are added, and the few of the core's end box a window does not reach
    // are subtracted, term by term (weights fixed here). When that would take more than one
    // term per target, or the core would vanish, the band spans the ends as they are.
    const Eigen::Index count = i1 - i0 + 1, middle = ct.offset + i0 + count / 2;
    const Eigen::Index forward_box_lo = box_first(i0 + count / 2 + fwd_[middle]);
    const Eigen::Index forward_box_hi = box_last(forward_box_lo);
    const Eigen::Index backward_box_hi = box_last(i0 + count / 2 - back_[middle]);
    const Eigen::Index backward_box_lo = box_first(backward_box_hi);
    Eigen::Index corrections = 0;
    bool one_box = backward_box_hi < forward_box_lo;
    for (Eigen::Index i = i0; i <= i1 && one_box; ++i) {
      const Eigen::Index lo = i - back_[ct.offset + i], hi = i + fwd_[ct.offset + i];
      corrections += std::abs(std::clamp(hi, forward_box_lo - 1, forward_box_hi) - hi) +
                     std::abs(std::clamp(lo, backward_box_lo, backward_box_hi + 1) - lo);
      one_box = hi >= backward_box_hi && lo <= forward_box_lo;  // what is subtracted lies in the core
    }
    if (one_box && corrections <= count) {
      tb.forward = {forward_box_lo, std::min(hi_max, forward_box_hi)};
      tb.backward = {std::max(lo_min, backward_box_lo), backward_box_hi};
    } else {
      tb.forward = {box_first(core_hi), hi_max};
      tb.backward = {lo_min, box_last(core_lo)};
    }
    tb.core_lo = tb.backward.hi + 1;
    tb.core_hi = tb.forward.lo - 1;
    if (tb.core_lo >= 0 && tb.core_hi < n && tb.core_lo <= tb.core_hi) {
      tb.core_first_box = ct.box_of[tb.core_lo];
      tb.core_last_box = ct.box_of[tb.core_hi];
    }
    // Band centres, half widths and offsets from the box (in units of delta).
    double centre_of[2], half[2], offset[2];
    const Band* bands[2] = {&tb.forward, &tb.backward};
    for (int b = 0; b < 2; ++b) {
      const double first = position(bands[b]->lo), last = position(bands[b]->hi);
      centre_of[b] = 0.5 * (first + last);
      half[b] = 0.5 * (last - first) / delta;
      offset[b] = (centre_of[b] - centre) / delta;
    }
    // Error of the band series: every term of the exact sum is |f_j| G_ij, and the factored
    // form errs by at most |f_j| G_ij e^(-2 alpha beta) times the series' remainder, with
    // G_ij <= exp(-(|D| - |beta| - |alpha|)^2) when that distance is positive.
    const double x = 2 * alpha_max * std::max(half[0], half[1]);
    const double distance = std::max(0.0, std::min(std::abs(offset[0]) - half[0], std::abs(offset[1]) - half[1]) - alpha_max);
    const int order = band_series_order(x, std::exp(-distance * distance), 0.5 * epsilon);
    if (order > kMaxBandOrder) continue;
    tb.direct = false;
    tb.band_order = order;
    band_order_ = std::max(band_order_, order);
    for (int b = 0; b < 2; ++b) {
      Band& band = b == 0 ? tb.forward : tb.backward;
      band.data = band_two_beta_.size();
      for (Eigen::Index u = band.lo; u <= band.hi; ++u) {
        const double x_u = position(u);
        band_two_beta_.push_back(2 * (x_u - centre_of[b]) / delta);
        const double d = (x_u - centre) / delta;
        band_weight_.push_back(std::exp(-d * d));
      }
    }
    tb.corrections_begin = correction_.size();
    for (Eigen::Index i = i0; i <= i1; ++i) {
      const Eigen::Index lo = i - back_[ct.offset + i], hi = i + fwd_[ct.offset + i];
      auto correct = [&](Eigen::Index u, double sign) {
        const double d = (position(u) - s[i]) / delta;
        correction_.push_back({i - i0, u - wraps(u) * n, sign * std::exp(-d * d)});
      };
      for (Eigen::Index u = hi + 1; u < tb.forward.lo; ++u) correct(u, -1.0);  // in the core, beyond the window
      for (Eigen::Index u = tb.backward.hi + 1; u < lo; ++u) correct(u, -1.0);
      for (Eigen::Index u = tb.forward.hi + 1; u <= hi; ++u) correct(u, 1.0);   // in the window, beyond the band
      for (Eigen::Index u = lo; u < tb.backward.lo; ++u) correct(u, 1.0);
    }
    tb.corrections_end = correction_.size();
    const Eigen::Index forward_count = tb.forward.hi - tb.forward.lo + 1, backward_count = tb.backward.hi - tb.backward.lo + 1;
    for (Eigen::Index i = i0; i <= i1; ++i) {
      // Moments row 0 (forward) and the last row (backward) are zero: for the windows that end
      // before the band begins (or begin after it ends).
      band_rows_[ct.offset + i] = {
          static_cast<std::int32_t>(std::clamp<Eigen::Index>(i + fwd_[ct.offset + i] - tb.forward.lo + 1, 0, forward_count)),
          static_cast<std::int32_t>(std::clamp<Eigen::Index>(i - back_[ct.offset + i] - tb.backward.lo, 0, backward_count))};
      const double a = (s[i] - centre) / delta;
      alpha_[ct.offset + i] = a;
      tau_forward_[ct.offset + i] = std::exp(2 * offset[0] * a - a * a);
      tau_backward_[ct.offset + i] = std::exp(2 * offset[1] * a - a * a);
    }
  }
}

void MatrixFreeLaplacian::direct_sums(const Contour& ct, Eigen::Index i0, Eigen::Index i1, const double* fc,
                                      double* oc) const {
  const double* s = s_.data() + ct.offset;
  const Eigen::Index n = ct.n;
  const double inv_4t = 1.0 / (4 * ct.t);
  for (Eigen::Index i = i0; i <= i1; ++i) {
    double sum = 0;
    for (Eigen::Index m = -back_[ct.offset + i]; m <= fwd_[ct.offset + i]; ++m) {
      const Eigen::Index j = ((i + m) % n + n) % n;
      const double d = detail::cyclic_distance(s[i], s[j], ct.P);
      sum += std::exp(-d * d * inv_4t) * fc[j];
    }
    oc[i] = sum;
  }
}

void MatrixFreeLaplacian::gauss_transform(const double* x, double* out, double* y, Scratch& scratch) const {
  if (x) scratch.weighted.resize(rows());
  for (const Contour& ct : contours_)
    contour_transform(ct, x ? x + ct.offset : nullptr, x ? scratch.weighted.data() + ct.offset : nullptr, out + ct.offset,
                      scratch.box_moments, y ? y + ct.offset : nullptr);
}

// What the kernels of one contour's product share (see matrix_free_kernels.inc).
struct MatrixFreeLaplacian::KernelArgs {
  const MatrixFreeLaplacian& op;
  const Contour& ct;
  const double* fc;  // mu x, from the contour's first row
  double* oc;        // its transform
  const double* xc;  // with yc, also y = c (out - x (G * mu)), box by box: see gauss_transform
  double* yc;
  double* H;  // Hermite moments, boxes x p
  int p;
  double inverse_factorial[64];
  // (L x)_i = c [ sum_j G_ij mu_j x_j - x_i sum_j G_ij mu_j ] (the j = i terms cancel).
  void finish(Eigen::Index i0, Eigen::Index i1) const {
    if (!yc) return;
    const double* transform_of_mass = op.transform_of_mass_.data() + ct.offset;
    for (Eigen::Index i = i0; i <= i1; ++i) yc[i] = ct.scale * (oc[i] - xc[i] * transform_of_mass[i]);
  }
};

// Each thread's scratch for the target boxes it takes.
struct MatrixFreeLaplacian::BoxScratch {
  double local[64];             // Taylor coefficients of the core, in taylor_column order
  std::vector<double> wrapped;  // a translation matrix computed on the spot
  std::vector<Pair> forward_rows, backward_rows;  // band moments
};

#define KERNEL(name) name##_plain
#define KernelVector Pair
#include "matrix_free_kernels.inc"
#undef KernelVector
#undef KERNEL
#if DIGILAP_WIDE_KERNELS
#pragma GCC push_options
#pragma GCC target("avx2,fma")
#define KERNEL(name) name##_wide
#define KernelVector Quad
#include "matrix_free_kernels.inc"
#undef KernelVector
#undef KERNEL
#pragma GCC pop_options
#endif

void MatrixFreeLaplacian::contour_transform(const Contour& ct, const double* xc, double* fc, double* oc,
                                            std::vector<double>& box_moments, double* yc) const {
  const double* mass = mass_.data() + ct.offset;
  KernelArgs args{*this, ct, xc ? fc : mass, oc, xc, yc, nullptr, order_, {}};
  args.inverse_factorial[0] = 1;
  for (int q = 1; q < 64; ++q) args.inverse_factorial[q] = args.inverse_factorial[q - 1] / q;
  auto weigh = [&](Eigen::Index i0, Eigen::Index i1) {  // f = mu x on rows i0..i1
    if (xc)
      for (Eigen::Index i = i0; i <= i1; ++i) fc[i] = mass[i] * xc[i];
  };
  const int p = order_;
  if (!ct.direct) box_moments.resize(std::max(box_moments.size(), static_cast<std::size_t>(ct.boxes) * p));
  args.H = box_moments.data();
  // The build of the per-box loops this operator runs, chosen once (wide_kernels_).
  auto box_moments_of = &MatrixFreeLaplacian::box_moments_plain;
  auto target_box_of = &MatrixFreeLaplacian::target_box_plain;
#if DIGILAP_WIDE_KERNELS
  if (wide_kernels_) {
    box_moments_of = &MatrixFreeLaplacian::box_moments_wide;
    target_box_of = &MatrixFreeLaplacian::target_box_wide;
  }
#endif
  // One parallel region, its loops separated by barriers only: on the project's virtual
  // machine each region's start and end cost a wake-up of the other thread, and a product
  // of 2-3 ms varied by up to 50% with them.
#pragma omp parallel
  {
    if (ct.direct) {
#pragma omp for schedule(static)
      for (Eigen::Index i = 0; i < ct.n; ++i) weigh(i, i);
#pragma omp for schedule(dynamic, 64)
      for (Eigen::Index i = 0; i < ct.n; ++i) {
        direct_sums(ct, i, i, args.fc, oc);
        args.finish(i, i);
      }
    } else {
      // 1. Hermite moments of every box, f weighed box by box on the way.
#pragma omp for schedule(static)
      for (Eigen::Index k = 0; k < ct.boxes; ++k) {
        weigh(ct.box_start[k], ct.box_start[k + 1] - 1);
        (this->*box_moments_of)(args, k);
      }
      // 2. Targets box by box (after the barrier: bands and corrections read f of other boxes).
      BoxScratch scratch;
      scratch.wrapped.resize(static_cast<std::size_t>(p) * taylor_columns(p));
#pragma omp for schedule(dynamic, 4)
      for (Eigen::Index kt = 0; kt < ct.boxes; ++kt) {
        const Eigen::Index i0 = ct.box_start[kt], i1 = ct.box_start[kt + 1] - 1;
        if (i0 > i1) continue;
        if (ct.plan[kt].direct) {
          direct_sums(ct, i0, i1, args.fc, oc);
          args.finish(i0, i1);
          continue;
        }
        (this->*target_box_of)(args, kt, scratch);
      }
    }
  }
}

void MatrixFreeLaplacian::apply(const double* x, double* y) const {
  // Scratch kept between products (a fresh 2 N doubles per product were page faults).
  scratch_.transformed.resize(rows());
  gauss_transform(x, scratch_.transformed.data(), y, scratch_);
}

void MatrixFreeLaplacian::apply_contour(std::size_t c, const double* x, double* y) const {
  apply_contour_with(c, x, y, scratch_);
}

void MatrixFreeLaplacian::apply_contour_with(std::size_t c, const double* x, double* y, Scratch& scratch) const {
  if (c >= contours_.size()) throw Error("MatrixFreeLaplacian::apply_contour: no contour " + std::to_string(c));
  const Contour& ct = contours_[c];
  scratch.weighted.resize(ct.n);
  scratch.transformed.resize(ct.n);
  contour_transform(ct, x, scratch.weighted.data(), scratch.transformed.data(), scratch.box_moments, y);
}

void MatrixFreeLaplacian::apply_contour_block(std::size_t c, const Eigen::MatrixXd& x, Eigen::MatrixXd& y) const {
  if (c >= contours_.size()) throw Error("MatrixFreeLaplacian::apply_contour_block: no contour " + std::to_string(c));
  if (x.rows() != contours_[c].n)
    throw Error("MatrixFreeLaplacian::apply_contour_block: the block has " + std::to_string(x.rows()) +
                " rows, contour " + std::to_string(c) + " has " + std::to_string(contours_[c].n));
  y.resize(x.rows(), x.cols());
  // One column per thread at a time. The product's own parallel loops then run on a team of
  // one (nested regions are inactive); its result does not depend on the team's size, so the
  // block equals the column-by-column products bit for bit, whatever the thread count.
  if (x.cols() < 2 || omp_get_max_threads() < 2 || omp_in_parallel()) {
    for (Eigen::Index k = 0; k < x.cols(); ++k) apply_contour(c, x.col(k).data(), y.col(k).data());
    return;
  }
#pragma omp parallel
  {
    Scratch scratch;
#pragma omp for schedule(dynamic, 1)
    for (Eigen::Index k = 0; k < x.cols(); ++k) apply_contour_with(c, x.col(k).data(), y.col(k).data(), scratch);
  }
}

Eigen::VectorXd MatrixFreeLaplacian::operator*(const Eigen::VectorXd& x) const {
  if (x.size() != rows()) throw Error("MatrixFreeLaplacian: the vector has the wrong size");
  Eigen::VectorXd y(rows());
  apply(x.data(), y.data());
  return y;
}

Eigen::VectorXd MatrixFreeLaplacian::apply_stiffness(const Eigen::VectorXd& x) const {
  return mass_.cwiseProduct(*this * x);
}

std::vector<double> MatrixFreeLaplacian::contour_t() const {
  std::vector<double> t;
  for (const Contour& ct : contours_) t.push_back(ct.t);
  return t;
}

std::vector<double> MatrixFreeLaplacian::contour_lengths() const {
  std::vector<double> lengths;
  for (const Contour& ct : contours_) lengths.push_back(ct.P);
  return lengths;
}

// --- Spectrum ------------------------------------------------------------------------------

namespace {

// C = M^(1/2) (-L_c) M^(-1/2) on the block of one contour c: symmetric (A = M L is), same
// eigenvalues as -A x = lambda M x there, eigenvectors y = M^(1/2) x.
class SymmetricForm {
public:
  SymmetricForm(const MatrixFreeLaplacian& op, std::size_t contour)
      : op_(op), contour_(contour), first_(op.row_offset()[contour]), n_(op.row_offset()[contour + 1] - first_),
        sqrt_mass_(op.mass().segment(first_, n_).cwiseSqrt()), z_(n_), w_(n_) {}
  Eigen::Index rows() const { return n_; }
  const Eigen::VectorXd& sqrt_mass() const { return sqrt_mass_; }
  // y = (c I - C) x
  void shifted(double c, const double* x_in, double* y_out) const {
    Eigen::Map<const Eigen::VectorXd> x(x_in, n_);
    Eigen::Map<Eigen::VectorXd> y(y_out, n_);
    z_ = x.cwiseQuotient(sqrt_mass_);
    op_.apply_contour(contour_, z_.data(), w_.data());
    y = c * x + sqrt_mass_.cwiseProduct(w_);
  }
  // Y = C X = -M^(1/2) L_c M^(-1/2) X: the columns' products side by side (apply_contour_block).
  void apply_block(const Eigen::MatrixXd& x, Eigen::MatrixXd& y) const {
    scaled_.resize(x.rows(), x.cols());  // one block, reused by every call
    const double* s = sqrt_mass_.data();
#pragma omp parallel for schedule(static)
    for (Eigen::Index k = 0; k < x.cols(); ++k)
      for (Eigen::Index i = 0; i < n_; ++i) scaled_(i, k) = x(i, k) / s[i];
    op_.apply_contour_block(contour_, scaled_, y);
#pragma omp parallel for schedule(static)
    for (Eigen::Index k = 0; k < y.cols(); ++k)
      for (Eigen::Index i = 0; i < n_; ++i) y(i, k) *= -s[i];
  }

private:
  const MatrixFreeLaplacian& op_;
  std::size_t contour_;
  Eigen::Index first_, n_;
  Eigen::VectorXd sqrt_mass_;
  mutable Eigen::VectorXd z_, w_;
  mutable Eigen::MatrixXd scaled_;
};

// Spectra's view of c I - C (largest eigenvalues = the wanted smallest of C).
class ShiftedSymmetricOp {
public:
  using Scalar = double;
  ShiftedSymmetricOp(const SymmetricForm& form, double c) : form_(form), c_(c) {}
  Eigen::Index rows() const { return form_.rows(); }
  Eigen::Index cols() const { return form_.rows(); }
  void perform_op(const double* x, double* y) const { form_.shifted(c_, x, y); }

private:
  const SymmetricForm& form_;
  double c_;
};

// Preconditioner for C from the 1D Laplacian along the arclength of the contour. The heat
// operator acts on a wave of frequency w as (1 - exp(-w^2 t)) / t; D2 = M^-1 K (K: the cyclic
// "1 / ds" stiffness of consecutive rows) acts as w^2, so g(D2) = D2 (I + t D2)^-1 follows the
// heat operator within a factor 1.3 at every frequency. T = (g(D2) + sigma)^-1 M^-1 (symmetric
// positive definite) = (I + t D2) S^-1 with S = (1 + sigma t) K + sigma M: one sparse
// tridiagonal (cyclic) factorization, O(N) (cyclic_tridiagonal.hpp). In the symmetric form: T_y = M^(1/2) T M^(1/2).
class ArclengthPreconditioner {
public:
  ArclengthPreconditioner(const MatrixFreeLaplacian& op, std::size_t contour)
      : t_(op.contour_t()[contour]), factor_(system(op, contour, t_, edge_weights_, sqrt_mass_)) {}

  // out = T_y r, column by column (each column's solve is a sequential sweep: the columns
  // are the parallel work, and each is computed the same way whatever the thread count).
  void apply_block(const Eigen::MatrixXd& r, Eigen::MatrixXd& out) const {
    const Eigen::Index n = r.rows();
    out.resize(n, r.cols());
#pragma omp parallel for schedule(static)
    for (Eigen::Index c = 0; c < r.cols(); ++c) {
      double* z = out.col(c).data();
      const double* rc = r.col(c).data();
      for (Eigen::Index i = 0; i < n; ++i) z[i] = sqrt_mass_[i] * rc[i];
      factor_.solve_in_place(z);  // z = S^-1 M^(1/2) r
      // out = M^(1/2) z + t M^(-1/2) K z, in place: z's neighbours are read before they are overwritten.
      const double z_first = z[0];
      double z_previous = z[n - 1];
      for (Eigen::Index i = 0; i < n; ++i) {
        const double zi = z[i], z_next = i + 1 < n ? z[i + 1] : z_first;
        const double kz = edge_weights_[i == 0 ? n - 1 : i - 1] * (zi - z_previous) + edge_weights_[i] * (zi - z_next);
        z[i] = sqrt_mass_[i] * zi + t_ * kz / sqrt_mass_[i];
        z_previous = zi;
      }
    }
  }

private:
  // S = (1 + sigma t) K + sigma M, with K's edge weights 1 / ds (edge i joins rows i and i + 1 mod n).
  static detail::CyclicTridiagonalLDLT system(const MatrixFreeLaplacian& op, std::size_t contour, double t,
                                              Eigen::VectorXd& edge_weights, Eigen::VectorXd& sqrt_mass) {
    const Eigen::Index first = op.row_offset()[contour], n = op.row_offset()[contour + 1] - first;
    const double length = op.contour_lengths()[contour];
    const Eigen::VectorXd mass = op.mass().segment(first, n);
    sqrt_mass = mass.cwiseSqrt();
    const double sigma = std::pow(2 * kPi / length, 2);  // the first non-zero eigenvalue's scale
    const Eigen::VectorXd s = op.arclength().segment(first, n);
    const double min_ds = 1e-6 * length / n;  // coincident rows: a large, finite weight
    edge_weights.resize(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      const double ds = i + 1 < n ? s[i + 1] - s[i] : s[0] + length - s[i];
      edge_weights[i] = 1.0 / std::max(ds, min_ds);
    }
    Eigen::VectorXd diagonal(n), coupling = -(1 + sigma * t) * edge_weights;
    for (Eigen::Index i = 0; i < n; ++i)
      diagonal[i] = (1 + sigma * t) * (edge_weights[i] + edge_weights[i == 0 ? n - 1 : i - 1]) + sigma * mass[i];
    return detail::CyclicTridiagonalLDLT(diagonal, coupling);
  }

  double t_;
  Eigen::VectorXd edge_weights_, sqrt_mass_;  // filled by system(), before factor_
  detail::CyclicTridiagonalLDLT factor_;
};

// The `count` smallest eigenpairs of contour c's block: dense when small, else preconditioned
// LOBPCG, else Lanczos. The block is connected (checked), so its kernel is simple.
Spectrum contour_spectrum(const MatrixFreeLaplacian& op, std::size_t contour, int count, const SpectrumOptions& o) {
  const SymmetricForm form(op, contour);
  const Eigen::Index n = form.rows();
  if (n <= detail::kDenseRows || 2 * count + 1 > n) {
    if (n > 3000)
      throw Error("smallest_eigenpairs: " + std::to_string(count) + " eigenpairs of a contour of " + std::to_string(n) +
                  " rows is more than half of them; ask for fewer");
    // The block of A column by column, from products with unit vectors (n products of O(n)).
    const Eigen::Index first = op.row_offset()[contour];
    Eigen::MatrixXd L(n, n);
    Eigen::VectorXd unit = Eigen::VectorXd::Zero(n);
    for (Eigen::Index j = 0; j < n; ++j) {
      unit[j] = 1;
      op.apply_contour(contour, unit.data(), L.col(j).data());
      unit[j] = 0;
    }
    const Eigen::VectorXd mass = op.mass().segment(first, n);
    return detail::dense_spectrum(mass.asDiagonal() * L, mass, count);
  }
  // Gershgorin on L: every eigenvalue of -L lies in [0, 2 max|L_ii|].
  const double c = 2.0 * op.diagonal().segment(op.row_offset()[contour], n).cwiseAbs().maxCoeff();
  Spectrum s;
  // Preconditioned LOBPCG first: about 10 iterations whatever h (165 products for 10
  // eigenpairs of the flower from h = 1e-2 to 1e-4), where Lanczos needs thousands as the
  // spectrum spreads to 2 / t. The block holds guard vectors beyond `count`, which speed up
  // the last wanted ones. Should it not converge (a preconditioner far from the operator),
  // Lanczos takes over. Residual tolerance: `tolerance` times the spectrum's bound c, the
  // same scale as Lanczos's Ritz-value test on c I - C.
  constexpr int kLobpcgIterations = 300;
  const Eigen::Index block = std::min<Eigen::Index>(n, count + std::max(4, count / 2));
  // LOBPCG's blocks, and the form's scaled copy of the block it multiplies.
  const double lobpcg_need = detail::lobpcg_bytes(n, block) + 8.0 * static_cast<double>(n) * static_cast<double>(block);
  if (block < n / 2 && lobpcg_need <= o.memory_limit_bytes) {
    const ArclengthPreconditioner preconditioner(op, contour);
    const detail::LobpcgResult r = detail::lobpcg(
        [&](const Eigen::MatrixXd& x, Eigen::MatrixXd& y) { form.apply_block(x, y); },
        [&](const Eigen::MatrixXd& x, Eigen::MatrixXd& y) { preconditioner.apply_block(x, y); },
        detail::lobpcg_start(n, block), count,
        o.tolerance * c, std::min(o.max_iterations, kLobpcgIterations), o.progress);
    if (r.converged) {
      s.eigenvalues = r.values;
      s.eigenvectors = form.sqrt_mass().cwiseInverse().asDiagonal() * r.vectors;  // M-orthonormal
      s.iterations = r.iterations;
      s.operations = r.products;
      detail::fix_signs(s.eigenvectors);
      return s;
    }
  }
  // Lanczos (Spectra) on c I - C, whose largest eigenvalues are the wanted ones.
  ShiftedSymmetricOp shifted(form, c);
  const int ncv = static_cast<int>(std::min<Eigen::Index>(n, o.subspace > 0 ? o.subspace : std::max(4 * count, 40)));
  const double lanczos_bytes = 2.0 * static_cast<double>(n) * (ncv + count) * sizeof(double);  // basis + result
  if (lanczos_bytes > o.memory_limit_bytes) {
    std::ostringstream msg;
    msg << "smallest_eigenpairs: " << count << " eigenpairs of " << n << " rows need about "
        << lobpcg_need / 1e9 << " GB (LOBPCG) or " << lanczos_bytes / 1e9
        << " GB (Lanczos), above the memory limit of " << o.memory_limit_bytes / 1e9 << " GB; ask for fewer";
    throw Error(msg.str());
  }
  Spectra::SymEigsSolver<ShiftedSymmetricOp> eigs(shifted, count, ncv);
  eigs.init();
  const Eigen::Index converged = eigs.compute(Spectra::SortRule::LargestAlge, o.max_iterations, o.tolerance,
                                              Spectra::SortRule::LargestAlge);
  detail::require_converged(eigs, converged, count, ncv);
  s.eigenvalues = c - eigs.eigenvalues().array();  // descending theta = ascending lambda
  s.eigenvectors = form.sqrt_mass().cwiseInverse().asDiagonal() * eigs.eigenvectors();  // M-orthonormal
  s.iterations = static_cast<int>(eigs.num_iterations());
  s.operations = static_cast<int>(eigs.num_operations());
  detail::fix_signs(s.eigenvectors);
  return s;
}

// Every contour's spectrum (min(count, n_c) pairs each), after checking that each contour is
// one connected block.
std::vector<detail::SpectrumPart> contour_parts(const MatrixFreeLaplacian& op, int count, const SpectrumOptions& o) {
  std::vector<detail::SpectrumPart> parts(op.contour_lengths().size());
  for (std::size_t c = 0; c < parts.size(); ++c) {
    const Eigen::Index first = op.row_offset()[c], n = op.row_offset()[c + 1] - first;
    if (!op.contour_is_connected(c)) {
      std::ostringstream msg;
      msg << "smallest_eigenpairs: on contour " << c << " the kernel's cut k sqrt(t) = " << op.cut()
          << " does not reach from every element to the next, so its elements fall into groups that do not "
             "interact; raise t or k, or use the factorized operator";
      throw Error(msg.str());
    }
    parts[c].rows.resize(static_cast<std::size_t>(n));
    std::iota(parts[c].rows.begin(), parts[c].rows.end(), first);
    parts[c].spectrum = contour_spectrum(op, c, static_cast<int>(std::min<Eigen::Index>(count, n)), o);
  }
  return parts;
}

}  // namespace

bool MatrixFreeLaplacian::contour_is_connected(std::size_t c) const {
  const Contour& ct = contours_.at(c);
  for (Eigen::Index i = 0; i < ct.n && ct.n > 1; ++i)
    if (fwd_[ct.offset + i] < 1) return false;
  return true;
}

Spectrum smallest_eigenpairs(const MatrixFreeLaplacian& op, const SpectrumOptions& o) {
  detail::check_eigen_request(op.mass(), o.count);
  // Contour by contour (the operator is block-diagonal by contour), then merged: repeated
  // eigenvalues of identical contours are all counted (spectrum_parts.hpp).
  Spectrum s = detail::merge_parts(contour_parts(op, o.count, o), op.rows(), o.count);
  detail::laplace_beltrami_by_contour(s, op.row_offset(), op.contour_t());
  return s;
}

std::vector<Spectrum> smallest_eigenpairs_per_contour(const MatrixFreeLaplacian& op, const SpectrumOptions& o) {
  if (o.count < 1) throw Error("smallest_eigenpairs_per_contour: count must be >= 1, got " + std::to_string(o.count));
  detail::check_eigen_request(op.mass(), 1);  // masses > 0
  std::vector<Spectrum> spectra;
  const std::vector<double> contour_t = op.contour_t();
  for (detail::SpectrumPart& part : contour_parts(op, o.count, o)) {
    spectra.push_back(std::move(part.spectrum));
    spectra.back().laplace_beltrami = laplace_beltrami_eigenvalues(spectra.back().eigenvalues, contour_t[spectra.size() - 1],
                                                                   &spectra.back().undefined_estimates);
  }
  return spectra;
}

}  // namespace curve
}  // namespace digilap

// --- Conjugate gradient on the matrix-free operator ------------------------------------------
// Eigen's iterative solvers accept any matrix type that provides a product with a vector: the
// wrapper below is (M - dt A) applied through MatrixFreeLaplacian (Eigen's "matrix-free solvers").

namespace digilap {
inline namespace curve {
class HeatStepMatrix;
}  // namespace curve
}  // namespace digilap

namespace Eigen::internal {
template <>
struct traits<digilap::HeatStepMatrix> : public traits<Eigen::SparseMatrix<double>> {};
}  // namespace Eigen::internal

namespace digilap {
inline namespace curve {

class HeatStepMatrix : public Eigen::EigenBase<HeatStepMatrix> {
public:
  using Scalar = double;
  using RealScalar = double;
  using StorageIndex = int;
  enum { ColsAtCompileTime = Eigen::Dynamic, MaxColsAtCompileTime = Eigen::Dynamic, IsRowMajor = false };
  HeatStepMatrix(const MatrixFreeLaplacian& op, double dt) : op_(op), dt_(dt) {}
  Eigen::Index rows() const { return op_.rows(); }
  Eigen::Index cols() const { return op_.rows(); }
  template <typename Rhs>
  Eigen::Product<HeatStepMatrix, Rhs, Eigen::AliasFreeProduct> operator*(const Eigen::MatrixBase<Rhs>& x) const {
    return Eigen::Product<HeatStepMatrix, Rhs, Eigen::AliasFreeProduct>(*this, x.derived());
  }
  // (M - dt M L) x = M (x - dt L x)
  Eigen::VectorXd multiply(const Eigen::VectorXd& x) const { return op_.mass().cwiseProduct(x - dt_ * (op_ * x)); }
  // Jacobi: the diagonal of M - dt A is mu_i (1 - dt L_ii).
  Eigen::VectorXd diagonal_values() const {
    return op_.mass().cwiseProduct((Eigen::VectorXd::Ones(rows()) - dt_ * op_.diagonal()));
  }

private:
  const MatrixFreeLaplacian& op_;
  double dt_;
};

/// Jacobi preconditioner from the wrapper's diagonal (Eigen's DiagonalPreconditioner needs
/// stored coefficients).
class JacobiPreconditioner {
public:
  JacobiPreconditioner() = default;
  template <typename M>
  explicit JacobiPreconditioner(const M& m) { compute(m); }
  template <typename M>
  JacobiPreconditioner& analyzePattern(const M&) { return *this; }
  template <typename M>
  JacobiPreconditioner& factorize(const M& m) { return compute(m); }
  template <typename M>
  JacobiPreconditioner& compute(const M& m) {
    inverse_ = m.diagonal_values().cwiseInverse();
    return *this;
  }
  template <typename Rhs>
  Eigen::VectorXd solve(const Rhs& b) const { return inverse_.cwiseProduct(b); }
  Eigen::ComputationInfo info() const { return Eigen::Success; }

private:
  Eigen::VectorXd inverse_;
};

}  // namespace curve
}  // namespace digilap

namespace Eigen::internal {
template <typename Rhs>
struct generic_product_impl<digilap::HeatStepMatrix, Rhs, SparseShape, DenseShape, GemvProduct>
    : generic_product_impl_base<digilap::HeatStepMatrix, Rhs, generic_product_impl<digilap::HeatStepMatrix, Rhs>> {
  using Scalar = typename Product<digilap::HeatStepMatrix, Rhs>::Scalar;
  template <typename Dest>
  static void scaleAndAddTo(Dest& dst, const digilap::HeatStepMatrix& lhs, const Rhs& rhs, const Scalar& alpha) {
    dst.noalias() += alpha * lhs.multiply(rhs);
  }
};
}  // namespace Eigen::internal

namespace digilap {
inline namespace curve {

Eigen::VectorXd heat_step_cg(const MatrixFreeLaplacian& op, const Eigen::VectorXd& u, double dt, double tolerance,
                             int* iterations) {
  require_positive("heat_step_cg: dt", dt);
  if (u.size() != op.rows()) throw Error("heat_step_cg: the vector has the wrong size");
  for (Eigen::Index i = 0; i < op.rows(); ++i)
    if (!(op.mass()[i] > 0)) throw Error("heat_step_cg: the mass of row " + std::to_string(i) + " is not > 0");
  const HeatStepMatrix K(op, dt);
  Eigen::ConjugateGradient<HeatStepMatrix, Eigen::Lower | Eigen::Upper, JacobiPreconditioner> cg;
  cg.setTolerance(tolerance);
  cg.setMaxIterations(1000);
  cg.compute(K);
  const Eigen::VectorXd next = cg.solveWithGuess(op.mass().cwiseProduct(u), u);
  if (iterations) *iterations = static_cast<int>(cg.iterations());
  if (cg.info() != Eigen::Success) {
    std::ostringstream msg;
    msg << "heat_step_cg: conjugate gradient did not converge (" << cg.iterations() << " iterations, error "
        << cg.error() << ")";
    throw Error(msg.str());
  }
  return next;
}

}  // namespace curve
}  // namespace digilap
