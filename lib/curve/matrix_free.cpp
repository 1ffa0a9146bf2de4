// The matrix-free contour operator: its plan (boxes, bands, Hermite expansions) and its products
// (the fast Gauss transform). Its spectrum is in matrix_free_spectrum.cpp, its CG heat step in
// matrix_free_heat_step.cpp.
#include "digilap/curve/matrix_free.hpp"
#include "matrix_free_plan.hpp"
#include "digilap/core/constants.hpp"

#include "digilap/core/error.hpp"
#include "core/cpu.hpp"
#include "core/eigen_checks.hpp"
#include "elements.hpp"
#include "cyclic_tridiagonal.hpp"

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
#define DIGILAP_WIDE_KERNELS DIGILAP_X86_64_GCC
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

MatrixFreeLaplacian::Plan::Plan(const ContourSet& contours, const Measures& measures, const HeatLaplacianOptions& options,
                                double epsilon) {
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

double MatrixFreeLaplacian::Plan::direct_share() const {
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
void MatrixFreeLaplacian::Plan::plan_contour(Contour& ct, double epsilon) {
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

void MatrixFreeLaplacian::Plan::direct_sums(const Contour& ct, Eigen::Index i0, Eigen::Index i1, const double* fc,
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

void MatrixFreeLaplacian::Plan::gauss_transform(const double* x, double* out, double* y, Scratch& scratch) const {
  if (x) scratch.weighted.resize(rows());
  for (const Contour& ct : contours_)
    contour_transform(ct, x ? x + ct.offset : nullptr, x ? scratch.weighted.data() + ct.offset : nullptr, out + ct.offset,
                      scratch.box_moments, y ? y + ct.offset : nullptr);
}

// What the kernels of one contour's product share (see matrix_free_kernels.inc).
struct MatrixFreeLaplacian::Plan::KernelArgs {
  const Plan& op;
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
struct MatrixFreeLaplacian::Plan::BoxScratch {
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

void MatrixFreeLaplacian::Plan::contour_transform(const Contour& ct, const double* xc, double* fc, double* oc,
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
  auto box_moments_of = &MatrixFreeLaplacian::Plan::box_moments_plain;
  auto target_box_of = &MatrixFreeLaplacian::Plan::target_box_plain;
#if DIGILAP_WIDE_KERNELS
  if (wide_kernels_) {
    box_moments_of = &MatrixFreeLaplacian::Plan::box_moments_wide;
    target_box_of = &MatrixFreeLaplacian::Plan::target_box_wide;
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

void MatrixFreeLaplacian::Plan::apply(const double* x, double* y) const {
  // Scratch kept between products (a fresh 2 N doubles per product were page faults).
  scratch_.transformed.resize(rows());
  gauss_transform(x, scratch_.transformed.data(), y, scratch_);
}

void MatrixFreeLaplacian::Plan::apply_contour(std::size_t c, const double* x, double* y) const {
  apply_contour_with(c, x, y, scratch_);
}

void MatrixFreeLaplacian::Plan::apply_contour_with(std::size_t c, const double* x, double* y, Scratch& scratch) const {
  if (c >= contours_.size()) throw Error("MatrixFreeLaplacian::apply_contour: no contour " + std::to_string(c));
  const Contour& ct = contours_[c];
  scratch.weighted.resize(ct.n);
  scratch.transformed.resize(ct.n);
  contour_transform(ct, x, scratch.weighted.data(), scratch.transformed.data(), scratch.box_moments, y);
}

void MatrixFreeLaplacian::Plan::apply_contour_block(std::size_t c, const Eigen::MatrixXd& x, Eigen::MatrixXd& y) const {
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

Eigen::VectorXd MatrixFreeLaplacian::Plan::operator*(const Eigen::VectorXd& x) const {
  if (x.size() != rows()) throw Error("MatrixFreeLaplacian: the vector has the wrong size");
  Eigen::VectorXd y(rows());
  apply(x.data(), y.data());
  return y;
}

Eigen::VectorXd MatrixFreeLaplacian::Plan::apply_stiffness(const Eigen::VectorXd& x) const {
  return mass_.cwiseProduct(*this * x);
}

std::vector<double> MatrixFreeLaplacian::Plan::contour_t() const {
  std::vector<double> t;
  for (const Contour& ct : contours_) t.push_back(ct.t);
  return t;
}

std::vector<double> MatrixFreeLaplacian::Plan::contour_lengths() const {
  std::vector<double> lengths;
  for (const Contour& ct : contours_) lengths.push_back(ct.P);
  return lengths;
}

bool MatrixFreeLaplacian::Plan::contour_is_connected(std::size_t c) const {
  const Contour& ct = contours_.at(c);
  for (Eigen::Index i = 0; i < ct.n && ct.n > 1; ++i)
    if (fwd_[ct.offset + i] < 1) return false;
  return true;
}


// --- The public class: forwards to its plan ------------------------------------------------

MatrixFreeLaplacian::MatrixFreeLaplacian(const ContourSet& contours, const Measures& measures, const HeatLaplacianOptions& options,
                                         double epsilon)
    : plan_(std::make_unique<Plan>(contours, measures, options, epsilon)) {}
MatrixFreeLaplacian::~MatrixFreeLaplacian() = default;
MatrixFreeLaplacian::MatrixFreeLaplacian(const MatrixFreeLaplacian& other) : plan_(std::make_unique<Plan>(*other.plan_)) {}
MatrixFreeLaplacian& MatrixFreeLaplacian::operator=(const MatrixFreeLaplacian& other) {
  if (this != &other) plan_ = std::make_unique<Plan>(*other.plan_);
  return *this;
}
MatrixFreeLaplacian::MatrixFreeLaplacian(MatrixFreeLaplacian&&) noexcept = default;
MatrixFreeLaplacian& MatrixFreeLaplacian::operator=(MatrixFreeLaplacian&&) noexcept = default;

Eigen::Index MatrixFreeLaplacian::rows() const { return plan_->rows(); }
Eigen::Index MatrixFreeLaplacian::cols() const { return plan_->cols(); }
double MatrixFreeLaplacian::t() const { return plan_->t(); }
double MatrixFreeLaplacian::length_scale() const { return plan_->length_scale(); }
double MatrixFreeLaplacian::cut() const { return plan_->cut(); }
int MatrixFreeLaplacian::order() const { return plan_->order(); }
int MatrixFreeLaplacian::band_order() const { return plan_->band_order(); }
bool MatrixFreeLaplacian::wide_kernels() const { return plan_->wide_kernels(); }
const Eigen::VectorXd& MatrixFreeLaplacian::mass() const { return plan_->mass(); }
const Eigen::VectorXd& MatrixFreeLaplacian::diagonal() const { return plan_->diagonal(); }
const std::vector<Eigen::Index>& MatrixFreeLaplacian::row_offset() const { return plan_->row_offset(); }
const Eigen::MatrixX2d& MatrixFreeLaplacian::positions() const { return plan_->positions(); }
const Eigen::VectorXd& MatrixFreeLaplacian::arclength() const { return plan_->arclength(); }
double MatrixFreeLaplacian::direct_share() const { return plan_->direct_share(); }
std::vector<double> MatrixFreeLaplacian::contour_t() const { return plan_->contour_t(); }
bool MatrixFreeLaplacian::contour_is_connected(std::size_t c) const { return plan_->contour_is_connected(c); }
std::vector<double> MatrixFreeLaplacian::contour_lengths() const { return plan_->contour_lengths(); }
void MatrixFreeLaplacian::apply(const double* x, double* y) const { plan_->apply(x, y); }
Eigen::VectorXd MatrixFreeLaplacian::operator*(const Eigen::VectorXd& x) const { return *plan_ * x; }
void MatrixFreeLaplacian::apply_contour(std::size_t c, const double* x, double* y) const { plan_->apply_contour(c, x, y); }
void MatrixFreeLaplacian::apply_contour_block(std::size_t c, const Eigen::MatrixXd& x, Eigen::MatrixXd& y) const {
  plan_->apply_contour_block(c, x, y);
}
Eigen::VectorXd MatrixFreeLaplacian::apply_stiffness(const Eigen::VectorXd& x) const { return plan_->apply_stiffness(x); }

}  // namespace curve
}  // namespace digilap
