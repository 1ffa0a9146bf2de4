#include "digilap/matrix_free.hpp"

#include "digilap/error.hpp"
#include "eigen_checks.hpp"
#include "elements.hpp"
#include "gaussian_kernel.hpp"
#include "lobpcg.hpp"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCholesky>
#include <Spectra/SymEigsSolver.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <tuple>

namespace digilap {

namespace {
constexpr double kPi = 3.14159265358979323846;

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
  t_ = heat_time(contours.h, options);
  cut_ = options.k * std::sqrt(t_);
  delta_ = std::sqrt(4 * t_);
  box_ = 0.5 * delta_;  // sources within a quarter of delta of their box centre
  // Sources and targets both lie within a quarter of delta of their box centres; the Hermite
  // and the Taylor truncations each get a tenth of the budget.
  order_ = hermite_order(0.25, 0.1 * epsilon);
  scale_ = 1.0 / (t_ * std::sqrt(4 * kPi * t_));

  const detail::Elements e = detail::gather_elements(contours, measures, options.placement);
  mass_ = e.mu;
  s_ = e.s;
  positions_ = e.positions;
  offset_ = e.offset;
  const Eigen::Index n_all = mass_.size();
  back_.assign(static_cast<std::size_t>(n_all), 0);
  fwd_.assign(static_cast<std::size_t>(n_all), 0);
  for (std::size_t c = 0; c + 1 < offset_.size(); ++c) {
    Contour ct;
    ct.offset = offset_[c];
    ct.n = offset_[c + 1] - offset_[c];
    ct.P = e.length[c];
    const double* s = s_.data() + ct.offset;
#pragma omp parallel for schedule(static)
    for (Eigen::Index i = 0; i < ct.n; ++i) {
      const detail::GeodesicWindow w = detail::geodesic_window(s, ct.n, i, ct.P, cut_);
      back_[ct.offset + i] = w.back;
      fwd_[ct.offset + i] = w.fwd;
    }
    ct.boxes = static_cast<Eigen::Index>(std::ceil(ct.P / box_));
    ct.direct = cut_ >= 0.5 * ct.P || ct.n < 64 || ct.boxes < 8;
    if (!ct.direct) {
      ct.box_of.resize(static_cast<std::size_t>(ct.n));
      ct.box_start.assign(static_cast<std::size_t>(ct.boxes + 1), ct.n);
      for (Eigen::Index j = ct.n - 1; j >= 0; --j) {
        const Eigen::Index k = std::clamp<Eigen::Index>(static_cast<Eigen::Index>(s[j] / box_), 0, ct.boxes - 1);
        ct.box_of[j] = k;
        ct.box_start[k] = j;
      }
      // Empty boxes start where the next non-empty one does.
      for (Eigen::Index k = ct.boxes - 1; k >= 0; --k) ct.box_start[k] = std::min(ct.box_start[k], ct.box_start[k + 1]);
    }
    contours_.push_back(std::move(ct));
  }
  transform_of_mass_.resize(n_all);
  gauss_transform(mass_.data(), transform_of_mass_.data());
  // L_ii = -c sum_{j != i} G(d_ij) mu_j; the transform includes j = i with G(0) = 1.
  diagonal_ = -scale_ * (transform_of_mass_ - mass_);
}

void MatrixFreeLaplacian::gauss_transform(const double* f, double* out) const {
  const int p = order_;
  for (const Contour& ct : contours_) {
    const double* s = s_.data() + ct.offset;
    const double* fc = f + ct.offset;
    double* oc = out + ct.offset;
    const Eigen::Index n = ct.n;
    const double inv_4t = 1.0 / (4 * t_);
    if (ct.direct) {
#pragma omp parallel for schedule(dynamic, 64)
      for (Eigen::Index i = 0; i < n; ++i) {
        double sum = 0;
        for (Eigen::Index m = -back_[ct.offset + i]; m <= fwd_[ct.offset + i]; ++m) {
          const Eigen::Index j = ((i + m) % n + n) % n;
          const double d = detail::cyclic_distance(s[i], s[j], ct.P);
          sum += std::exp(-d * d * inv_4t) * fc[j];
        }
        oc[i] = sum;
      }
      continue;
    }
    // 1. Prefix sums, box by box, of the Hermite moments f_j v_j^n / n!, v_j = (s_j - c_k) / delta.
    // Reused between products: allocating (and page-faulting) N x p doubles each time cost
    // more than the transform with two threads.
    prefix_.resize(std::max(prefix_.size(), static_cast<std::size_t>(n) * p));
    double* Q = prefix_.data();
    double inverse_factorial[64];
    inverse_factorial[0] = 1;
    for (int q = 1; q < p; ++q) inverse_factorial[q] = inverse_factorial[q - 1] / q;
    const double inv_delta = 1.0 / delta_;
#pragma omp parallel for schedule(static)
    for (Eigen::Index k = 0; k < ct.boxes; ++k) {
      const double centre = (k + 0.5) * box_;
      double acc[64] = {0}, power[64];
      for (Eigen::Index j = ct.box_start[k]; j < ct.box_start[k + 1]; ++j) {
        // f_j v^q as four interleaved chains (v^q = v^(q-4) v^4): one chain of p dependent
        // products per source was the hot spot. 1/q! from a table (a division per term was).
        const double v = (s[j] - centre) * inv_delta, v2 = v * v, v4 = v2 * v2;
        power[0] = fc[j];
        power[1] = power[0] * v;
        power[2] = power[0] * v2;
        power[3] = power[1] * v2;
        for (int q = 4; q < p; ++q) power[q] = power[q - 4] * v4;
        double* row = Q + static_cast<std::size_t>(j) * p;
        for (int q = 0; q < p; ++q) {
          acc[q] += power[q] * inverse_factorial[q];
          row[q] = acc[q];
        }
      }
    }
    // 2. Targets box by box. The sources every target of a box sees (the "core" of their
    // windows) are gathered once into a Taylor expansion about the box centre (Hermite to
    // Taylor translation, O(p^2) per source box): each target then pays O(p) for them. The few
    // sources near the ends of its own window (the "edges", where the windows of the box's
    // targets differ) are evaluated from their Hermite moments, as is the whole window when the
    // core is empty. The window of every row is thus summed exactly as the explicit matrix does.
    const double P = ct.P;
    auto for_segments = [&](Eigen::Index a, Eigen::Index b, auto&& segment) {  // unwrapped a..b
      auto piece = [&](Eigen::Index pa, Eigen::Index pb, double shift) {
        for (Eigen::Index k = ct.box_of[pa]; k <= ct.box_of[pb]; ++k) {
          const Eigen::Index first = std::max(pa, ct.box_start[k]), last = std::min(pb, ct.box_start[k + 1] - 1);
          if (first <= last) segment(k, first, last, shift);
        }
      };
      if (a > b) return;
      if (a < 0) piece(a + n, std::min<Eigen::Index>(b, -1) + n, -P);  // behind the contour's start
      if (b >= 0 && a <= n - 1) piece(std::max<Eigen::Index>(a, 0), std::min(b, n - 1), 0.0);
      if (b >= n) piece(std::max(a, n) - n, b - n, P);                  // past its end
    };
    // Moments of sources first..last of box k into m[0], m[stride], ... (stride > 1: a lane
    // of a batch laid out moment-major).
    auto moments_of = [&](Eigen::Index k, Eigen::Index first, Eigen::Index last, double* m, int stride = 1) {
      const double* qa = Q + static_cast<std::size_t>(last) * p;
      if (first > ct.box_start[k]) {
        const double* qb = Q + static_cast<std::size_t>(first - 1) * p;
        for (int q = 0; q < p; ++q) m[q * stride] = qa[q] - qb[q];
      } else {
        for (int q = 0; q < p; ++q) m[q * stride] = qa[q];
      }
    };
    // h_0 .. h_{count-1} at u: h_n(u) = H_n(u) exp(-u^2).
    auto hermite = [](double u, int count, double* h) {
      h[0] = std::exp(-u * u);
      if (count > 1) h[1] = 2 * u * h[0];
      for (int q = 1; q + 1 < count; ++q) h[q + 1] = 2 * u * h[q] - 2 * q * h[q - 1];
    };
    // Core source boxes sit at whole box offsets d from the target box (u = d box / delta), so
    // their Hermite values are tabulated once per product; only the segments that wrap
    // around the contour's ends (shifted by P) are evaluated on the spot.
    const int terms = 2 * p - 1;
    const auto reach = static_cast<Eigen::Index>(std::ceil(cut_ / box_)) + 2;
    std::vector<double> hermite_at_offset(static_cast<std::size_t>(2 * reach + 1) * terms);
    for (Eigen::Index d = -reach; d <= reach; ++d)
      hermite(static_cast<double>(d) * box_ / delta_, terms, &hermite_at_offset[static_cast<std::size_t>(d + reach) * terms]);
#pragma omp parallel
    {
      double moments[64], h_wrapped[128], local[64];
      struct Job {
        Eigen::Index target, box, first, last;
        double u;
      };
      constexpr int kBatch = 8;
      std::vector<Job> jobs;
      std::vector<double> offsets;  // (s_i - centre) / delta for the targets of a box
#pragma omp for schedule(dynamic, 4)
      for (Eigen::Index kt = 0; kt < ct.boxes; ++kt) {
        const Eigen::Index i0 = ct.box_start[kt], i1 = ct.box_start[kt + 1] - 1;
        if (i0 > i1) continue;
        const double centre = (kt + 0.5) * box_;
        Eigen::Index core_lo = -n, core_hi = 2 * n;  // the intersection of the windows of i0..i1
        for (Eigen::Index i = i0; i <= i1; ++i) {
          core_lo = std::max(core_lo, i - back_[ct.offset + i]);
          core_hi = std::min(core_hi, i + fwd_[ct.offset + i]);
        }
        const bool core = core_lo <= core_hi;
        for (int q = 0; q < p; ++q) local[q] = 0;
        if (core)
          for_segments(core_lo, core_hi, [&](Eigen::Index k, Eigen::Index first, Eigen::Index last, double shift) {
            moments_of(k, first, last, moments);
            const Eigen::Index d = kt - k;
            const double* h = h_wrapped;
            if (shift == 0.0 && d >= -reach && d <= reach)
              h = hermite_at_offset.data() + static_cast<std::size_t>(d + reach) * terms;
            else
              hermite((centre - ((k + 0.5) * box_ + shift)) / delta_, terms, h_wrapped);
            // B_m = (-1)^m / m! sum_n A_n h_{n+m}(u0), since d/du h_n = -h_{n+1}.
            double factor = 1.0;
            for (int m = 0; m < p; ++m) {
              double sum = 0;
              for (int q = 0; q < p; ++q) sum += moments[q] * h[q + m];
              local[m] += factor * sum;
              factor *= -1.0 / (m + 1);
            }
          });
        // Window ends are queued, then evaluated kBatch at a time: the Hermite recurrence is
        // a chain of dependent multiply-adds, and running kBatch independent chains side by
        // side (vectorized) hides its latency, which otherwise dominates.
        jobs.clear();
        for (Eigen::Index i = i0; i <= i1; ++i) {
          auto queue = [&](Eigen::Index k, Eigen::Index first, Eigen::Index last, double shift) {
            jobs.push_back({i, k, first, last, (s[i] - ((k + 0.5) * box_ + shift)) / delta_});
          };
          const Eigen::Index lo = i - back_[ct.offset + i], hi = i + fwd_[ct.offset + i];
          if (core) {
            for_segments(lo, core_lo - 1, queue);
            for_segments(core_hi + 1, hi, queue);
          } else {
            for_segments(lo, hi, queue);
          }
          oc[i] = 0;
        }
        // The core's Taylor expansion at every target of the box: Horner steps in lockstep
        // across targets (one dependent chain per target otherwise).
        if (core) {
          const Eigen::Index count = i1 - i0 + 1;
          offsets.resize(static_cast<std::size_t>(count));
          double* w = offsets.data();
          for (Eigen::Index i = 0; i < count; ++i) w[i] = (s[i0 + i] - centre) / delta_;
          double* out_box = oc + i0;
          for (int m = p - 1; m >= 0; --m) {
            const double coefficient = local[m];
#pragma omp simd
            for (Eigen::Index i = 0; i < count; ++i) out_box[i] = out_box[i] * w[i] + coefficient;
          }
        }
        for (std::size_t b = 0; b < jobs.size(); b += kBatch) {
          const int lanes = static_cast<int>(std::min<std::size_t>(kBatch, jobs.size() - b));
          double mom[64][kBatch], u[kBatch] = {}, h0[kBatch], h1[kBatch], acc[kBatch];
          for (int l = 0; l < kBatch; ++l) {
            if (l >= lanes) {  // idle lanes: zero moments (not the whole 64 x kBatch block)
              for (int q = 0; q < p; ++q) mom[q][l] = 0;
              continue;
            }
            const Job& job = jobs[b + l];
            moments_of(job.box, job.first, job.last, &mom[0][l], kBatch);
            u[l] = job.u;
          }
          for (int l = 0; l < kBatch; ++l) h0[l] = u[l] * u[l];
          gaussian_weights(h0, kBatch, 1.0, 1.0);  // exp(-u^2), kBatch at a time (libmvec)
#pragma omp simd
          for (int l = 0; l < kBatch; ++l) {
            h1[l] = 2 * u[l] * h0[l];
            acc[l] = mom[0][l] * h0[l] + mom[1][l] * h1[l];
          }
          for (int q = 1; q + 1 < p; ++q) {
#pragma omp simd
            for (int l = 0; l < kBatch; ++l) {
              const double h2 = 2 * u[l] * h1[l] - 2 * q * h0[l];
              acc[l] += mom[q + 1][l] * h2;
              h0[l] = h1[l];
              h1[l] = h2;
            }
          }
          for (int l = 0; l < lanes; ++l) oc[jobs[b + l].target] += acc[l];
        }
      }
    }
  }
}

void MatrixFreeLaplacian::apply(const double* x, double* y) const {
  const Eigen::Index n = rows();
  // Scratch kept between products (a fresh 2 N doubles per product were page faults).
  weighted_.resize(n);
  transformed_.resize(n);
  double* f = weighted_.data();
  double* g = transformed_.data();
#pragma omp parallel for schedule(static)
  for (Eigen::Index i = 0; i < n; ++i) f[i] = mass_[i] * x[i];
  gauss_transform(f, g);
  // (L x)_i = c [ sum_j G_ij mu_j x_j - x_i sum_j G_ij mu_j ] (the j = i terms cancel).
#pragma omp parallel for schedule(static)
  for (Eigen::Index i = 0; i < n; ++i) y[i] = scale_ * (g[i] - x[i] * transform_of_mass_[i]);
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

std::vector<double> MatrixFreeLaplacian::contour_lengths() const {
  std::vector<double> lengths;
  for (const Contour& ct : contours_) lengths.push_back(ct.P);
  return lengths;
}

// --- Spectrum ------------------------------------------------------------------------------

namespace {

// C = M^(1/2) (-L) M^(-1/2): symmetric (A = M L is), same eigenvalues as -A x = lambda M x,
// eigenvectors y = M^(1/2) x.
class SymmetricForm {
public:
  explicit SymmetricForm(const MatrixFreeLaplacian& op) : op_(op), sqrt_mass_(op.mass().cwiseSqrt()), z_(op.rows()), w_(op.rows()) {}
  const Eigen::VectorXd& sqrt_mass() const { return sqrt_mass_; }
  // y = (c I - C) x
  void shifted(double c, const double* x_in, double* y_out) const {
    Eigen::Map<const Eigen::VectorXd> x(x_in, op_.rows());
    Eigen::Map<Eigen::VectorXd> y(y_out, op_.rows());
    z_ = x.cwiseQuotient(sqrt_mass_);
    op_.apply(z_.data(), w_.data());
    y = c * x + sqrt_mass_.cwiseProduct(w_);
  }
  // Y = C X = -(0 I - C) X, column by column.
  void apply_block(const Eigen::MatrixXd& x, Eigen::MatrixXd& y) const {
    y.resize(x.rows(), x.cols());
    for (Eigen::Index k = 0; k < x.cols(); ++k) {
      shifted(0.0, x.col(k).data(), y.col(k).data());
      y.col(k) = -y.col(k);
    }
  }

private:
  const MatrixFreeLaplacian& op_;
  Eigen::VectorXd sqrt_mass_;
  mutable Eigen::VectorXd z_, w_;
};

// Spectra's view of c I - C (largest eigenvalues = the wanted smallest of C).
class ShiftedSymmetricOp {
public:
  using Scalar = double;
  ShiftedSymmetricOp(const SymmetricForm& form, Eigen::Index n, double c) : form_(form), n_(n), c_(c) {}
  Eigen::Index rows() const { return n_; }
  Eigen::Index cols() const { return n_; }
  void perform_op(const double* x, double* y) const { form_.shifted(c_, x, y); }

private:
  const SymmetricForm& form_;
  Eigen::Index n_;
  double c_;
};

// Preconditioner for C from the 1D Laplacian along the arclength. The heat operator acts on a
// wave of frequency w as (1 - exp(-w^2 t)) / t; D2 = M^-1 K (K: the cyclic "1 / ds" stiffness
// of consecutive rows) acts as w^2, so g(D2) = D2 (I + t D2)^-1 follows the heat operator
// within a factor 1.3 at every frequency. T = (g(D2) + sigma)^-1 M^-1 (symmetric positive
// definite) = (I + t D2) S^-1 with S = (1 + sigma t) K + sigma M: one sparse tridiagonal
// (cyclic) factorization, O(N). In the symmetric form: T_y = M^(1/2) T M^(1/2).
class ArclengthPreconditioner {
public:
  explicit ArclengthPreconditioner(const MatrixFreeLaplacian& op) : sqrt_mass_(op.mass().cwiseSqrt()), t_(op.t()) {
    const Eigen::Index n = op.rows();
    const std::vector<double> lengths = op.contour_lengths();
    const double longest = *std::max_element(lengths.begin(), lengths.end());
    const double sigma = std::pow(2 * kPi / longest, 2);  // the first non-zero eigenvalue's scale
    std::vector<Eigen::Triplet<double>> k_entries, s_entries;
    const Eigen::VectorXd& s = op.arclength();
    for (std::size_t c = 0; c < lengths.size(); ++c) {
      const Eigen::Index first = op.row_offset()[c], count = op.row_offset()[c + 1] - first;
      const double min_ds = 1e-6 * lengths[c] / count;  // coincident rows: a large, finite weight
      for (Eigen::Index a = 0; a < count; ++a) {
        const Eigen::Index i = first + a, j = first + (a + 1) % count;
        if (i == j) continue;
        double ds = s[j] - s[i];
        if (a + 1 == count) ds += lengths[c];
        const double w = 1.0 / std::max(ds, min_ds);
        for (auto [r, col, v] : {std::tuple{i, i, w}, {j, j, w}, {i, j, -w}, {j, i, -w}}) k_entries.emplace_back(r, col, v);
      }
    }
    stiffness_.resize(n, n);
    stiffness_.setFromTriplets(k_entries.begin(), k_entries.end());
    Eigen::SparseMatrix<double> system = (1 + sigma * t_) * stiffness_;
    for (Eigen::Index i = 0; i < n; ++i) system.coeffRef(i, i) += sigma * op.mass()[i];
    solver_.compute(system);
    if (solver_.info() != Eigen::Success) throw Error("smallest_eigenpairs: the preconditioner could not be factorized");
  }
  void apply_block(const Eigen::MatrixXd& r, Eigen::MatrixXd& out) const {
    scaled_.noalias() = sqrt_mass_.asDiagonal() * r;  // buffers reused: no page faults per call
    z_ = solver_.solve(scaled_);
    out.noalias() = stiffness_ * z_;
    out = sqrt_mass_.asDiagonal() * z_ + t_ * (sqrt_mass_.cwiseInverse().asDiagonal() * out);
  }

private:
  Eigen::VectorXd sqrt_mass_;
  double t_;
  Eigen::SparseMatrix<double> stiffness_;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver_;
  mutable Eigen::MatrixXd scaled_, z_;
};

}  // namespace

Spectrum smallest_eigenpairs(const MatrixFreeLaplacian& op, const SpectrumOptions& o) {
  const Eigen::Index n = op.rows();
  detail::check_eigen_request(op.mass(), o.count);
  // Gershgorin on L: every eigenvalue of -L lies in [0, 2 max|L_ii|].
  const double c = 2.0 * op.diagonal().cwiseAbs().maxCoeff();
  const SymmetricForm form(op);
  Spectrum s;
  // Preconditioned LOBPCG first: about 10 iterations whatever h (165 products for 10
  // eigenpairs of the flower from h = 1e-2 to 1e-4), where Lanczos needs thousands as the
  // spectrum spreads to 2 / t. The block holds guard vectors beyond `count`, which speed up
  // the last wanted ones. Should it not converge (a preconditioner far from the operator),
  // Lanczos takes over. Residual tolerance: `tolerance` times the spectrum's bound c, the
  // same scale as Lanczos's Ritz-value test on c I - C.
  constexpr int kLobpcgIterations = 300;
  const Eigen::Index block = std::min<Eigen::Index>(n, o.count + std::max(4, o.count / 2));
  const double lobpcg_need = detail::lobpcg_bytes(n, block);
  if (block < n / 2 && lobpcg_need <= o.memory_limit_bytes) {
    const ArclengthPreconditioner preconditioner(op);
    Eigen::MatrixXd start(n, block);
    std::uint64_t state = 0x9e3779b97f4a7c15ULL;  // a fixed start: reproducible runs
    for (Eigen::Index k = 0; k < start.size(); ++k) {
      state = state * 6364136223846793005ULL + 1442695040888963407ULL;
      start.data()[k] = static_cast<double>(state >> 11) * 0x1.0p-53 - 0.5;
    }
    const detail::LobpcgResult r = detail::lobpcg(
        [&](const Eigen::MatrixXd& x, Eigen::MatrixXd& y) { form.apply_block(x, y); },
        [&](const Eigen::MatrixXd& x, Eigen::MatrixXd& y) { preconditioner.apply_block(x, y); }, std::move(start), o.count,
        o.tolerance * c, std::min(o.max_iterations, kLobpcgIterations), o.progress);
    if (r.converged) {
      s.eigenvalues = r.values;
      s.eigenvectors = form.sqrt_mass().cwiseInverse().asDiagonal() * r.vectors;  // M-orthonormal
      s.iterations = r.iterations;
      s.operations = r.products;
      return s;
    }
  }
  // Lanczos (Spectra) on c I - C, whose largest eigenvalues are the wanted ones.
  ShiftedSymmetricOp shifted(form, n, c);
  const int ncv = static_cast<int>(std::min<Eigen::Index>(n, o.subspace > 0 ? o.subspace : std::max(4 * o.count, 40)));
  const double lanczos_bytes = 2.0 * static_cast<double>(n) * (ncv + o.count) * sizeof(double);  // basis + result
  if (lanczos_bytes > o.memory_limit_bytes) {
    std::ostringstream msg;
    msg << "smallest_eigenpairs: " << o.count << " eigenpairs of " << n << " rows need about "
        << lobpcg_need / 1e9 << " GB (LOBPCG) or " << lanczos_bytes / 1e9
        << " GB (Lanczos), above the memory limit of " << o.memory_limit_bytes / 1e9 << " GB; ask for fewer";
    throw Error(msg.str());
  }
  Spectra::SymEigsSolver<ShiftedSymmetricOp> eigs(shifted, o.count, ncv);
  eigs.init();
  const Eigen::Index converged = eigs.compute(Spectra::SortRule::LargestAlge, o.max_iterations, o.tolerance,
                                              Spectra::SortRule::LargestAlge);
  detail::require_converged(eigs, converged, o.count, ncv);
  s.eigenvalues = c - eigs.eigenvalues().array();  // descending theta = ascending lambda
  s.eigenvectors = form.sqrt_mass().cwiseInverse().asDiagonal() * eigs.eigenvectors();  // M-orthonormal
  s.iterations = static_cast<int>(eigs.num_iterations());
  s.operations = static_cast<int>(eigs.num_operations());
  return s;
}

}  // namespace digilap

// --- Conjugate gradient on the matrix-free operator ------------------------------------------
// Eigen's iterative solvers accept any matrix type that provides a product with a vector: the
// wrapper below is (M - dt A) applied through MatrixFreeLaplacian (Eigen's "matrix-free solvers").

namespace digilap {
class HeatStepMatrix;
}

namespace Eigen::internal {
template <>
struct traits<digilap::HeatStepMatrix> : public traits<Eigen::SparseMatrix<double>> {};
}  // namespace Eigen::internal

namespace digilap {

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

}  // namespace digilap
