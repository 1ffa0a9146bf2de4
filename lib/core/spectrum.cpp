#include "digilap/core/spectrum.hpp"
#include "digilap/core/constants.hpp"

#include "digilap/core/error.hpp"
#include "components.hpp"
#include "massless.hpp"
#include "eigen_checks.hpp"
#include "lobpcg.hpp"
#include "spectrum_parts.hpp"

#include <Eigen/SparseCholesky>
#include <Spectra/SymGEigsShiftSolver.h>
#include <omp.h>

#include <array>
#include <cmath>
#include <tuple>
#include <utility>
#include <vector>
#include <memory>
#include <limits>
#include <exception>
#include <sstream>

namespace digilap {

namespace {

using ColMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

// Eigen's SimplicialLDLT with the size of its factor, known from the symbolic analysis alone.
class SimplicialLDLT : public Eigen::SimplicialLDLT<ColMatrix> {
public:
  /// Flops of the numeric factorization, sum over columns of (nonzeros below the diagonal)^2.
  double factorization_flops() const { return m_nonZerosPerCol.cast<double>().array().square().sum(); }
  /// Bytes of the factor L (values and row indices) and of D.
  double factor_bytes() const { return 12.0 * m_nonZerosPerCol.cast<double>().sum() + 8.0 * static_cast<double>(m_nonZerosPerCol.size()); }
};

// y = (-A - sigma M)^{-1} x through a simplicial LDL^T: the natural factorization for this
// symmetric positive definite matrix (Spectra's generic sparse shift-solve uses SparseLU).
// The pattern is analysed once: a new shift, or the inertia at another sigma, only refactorizes.
class ShiftInvertOp {
public:
  using Scalar = double;
  ShiftInvertOp(const SparseMatrix& A, const Eigen::VectorXd& mass) : mass_(mass) {
    ColMatrix identity(A.rows(), A.cols());
    identity.setIdentity();
    minus_A_ = -A;
    minus_A_ += 0.0 * identity;  // every diagonal entry stored: shifts keep the pattern
    solver_.analyzePattern(minus_A_);
  }
  Eigen::Index rows() const { return mass_.size(); }
  Eigen::Index cols() const { return mass_.size(); }
  void set_shift(double sigma) {
    if (!factorize(sigma))
      throw Error("smallest_eigenpairs: the factorization of -A - sigma M failed (is A negative semidefinite?)");
  }
  void perform_op(const double* x_in, double* y_out) const {
    Eigen::Map<const Eigen::VectorXd> x(x_in, rows());
    Eigen::Map<Eigen::VectorXd> y(y_out, rows());
    y = solver_.solve(x);
  }
  /// How many eigenvalues of -A x = lambda M x lie below sigma: the negative pivots of the
  /// LDL^T of -A - sigma M (Sylvester's law of inertia); -1 if it cannot be factorized.
  Eigen::Index eigenvalues_below(double sigma) {
    if (!factorize(sigma)) return -1;
    return (solver_.vectorD().array() < 0).count();
  }
  double factorization_flops() const { return solver_.factorization_flops(); }
  /// The factor, the stored -A and the shifted copy refactorized for each shift.
  double bytes() const { return solver_.factor_bytes() + 2 * 12.0 * static_cast<double>(minus_A_.nonZeros()); }

private:
  bool factorize(double sigma) {
    ColMatrix K = minus_A_;
    for (Eigen::Index i = 0; i < K.outerSize(); ++i) K.coeffRef(i, i) -= sigma * mass_[i];
    solver_.factorize(K);
    return solver_.info() == Eigen::Success;
  }
  ColMatrix minus_A_;
  Eigen::VectorXd mass_;
  SimplicialLDLT solver_;
};

// y = M x with M = diag(mass).
class MassOp {
public:
  using Scalar = double;
  explicit MassOp(const Eigen::VectorXd& mass) : mass_(mass) {}
  Eigen::Index rows() const { return mass_.size(); }
  Eigen::Index cols() const { return mass_.size(); }
  void perform_op(const double* x_in, double* y_out) const {
    for (Eigen::Index i = 0; i < mass_.size(); ++i) y_out[i] = mass_[i] * x_in[i];
  }

private:
  const Eigen::VectorXd& mass_;
};

}  // namespace

namespace {

// The 64-point Gauss-Legendre rule on [-1, 1] (Newton on P_64 from Chebyshev's guesses), made once.
const std::array<std::pair<double, double>, 64>& gauss_legendre_64() {
  static const std::array<std::pair<double, double>, 64> rule = [] {
    constexpr int n = 64;
    std::array<std::pair<double, double>, n> nodes{};
    for (int i = 0; i < n; ++i) {
      double x = std::cos(kPi * (i + 0.75) / (n + 0.5)), derivative = 1;
      for (int iteration = 0; iteration < 100; ++iteration) {
        double p0 = 1, p1 = x;
        for (int m = 2; m <= n; ++m) std::tie(p0, p1) = std::make_pair(p1, ((2 * m - 1) * x * p1 - (m - 1) * p0) / m);
        derivative = n * (x * p1 - p0) / (x * x - 1);
        const double step = p1 / derivative;
        x -= step;
        if (std::abs(step) < 1e-16) break;
      }
      nodes[static_cast<std::size_t>(i)] = {x, 2 / ((1 - x * x) * derivative * derivative)};
    }
    return nodes;
  }();
  return rule;
}

// The cut kernel's F(a) = (1 - e^(-a)) - tail(a), tail(a) the part of the whole Gaussian's
// average of (1 - e^(-i omega.y)) beyond the cut, a = mu t. In units of 2 sqrt(t) (r = |y| /
// 2 sqrt(t), the cut at r = k / 2) the kernel's radial density is 2 r exp(-r^2) with the angular
// mean 1 - J0(2 sqrt(a) r) in two dimensions, and (2 / sqrt(pi)) exp(-r^2) with 1 - cos(2 sqrt(a) r)
// in one. The tail is small (about 0.12% of F at k = 6, its second moment's share), so a fixed Gauss-Legendre rule over
// [k/2, k/2 + 6] (the density beyond is below exp(-36)) is exact to rounding for the a of the
// eigenvalues that have an estimate (a below about 10: the integrand's few oscillations). Written
// here because neither Eigen nor the standard library has a quadrature rule.
class CutKernelSymbol {
public:
  explicit CutKernelSymbol(const KernelCut& kernel) : dimension_(kernel.dimension), cut_(kernel.k / 2) {
    if (std::isinf(cut_)) return;
    for (const auto& [x, weight] : gauss_legendre_64()) {  // mapped to [cut, cut + 6]
      const double r = cut_ + 3 * (x + 1);
      nodes_.push_back(r);
      weights_.push_back(3 * weight * (dimension_ == 2 ? 2 * r * std::exp(-r * r) : 2 / std::sqrt(kPi) * std::exp(-r * r)));
    }
  }
  bool whole() const { return nodes_.empty(); }
  /// The kernel's mass: F's limit for large a, where the operator's spectrum ends.
  double mass() const { return 1 - tail_mass(); }
  double operator()(double a) const {
    double tail = 0;
    const double s = 2 * std::sqrt(a);
    for (std::size_t q = 0; q < nodes_.size(); ++q)
      tail += weights_[q] * (1 - (dimension_ == 2 ? std::cyl_bessel_j(0.0, s * nodes_[q]) : std::cos(s * nodes_[q])));
    return -std::expm1(-a) - tail;
  }

private:
  double tail_mass() const {
    if (whole()) return 0;
    return dimension_ == 2 ? std::exp(-cut_ * cut_) : std::erfc(cut_);
  }
  int dimension_;
  double cut_;
  std::vector<double> nodes_, weights_;
};

}  // namespace

KernelCut kernel_cut_of(const HeatOperator& op) {
  KernelCut kernel;
  kernel.dimension = op.dimension;
  if (op.t > 0 && op.cut > 0) kernel.k = op.cut / std::sqrt(op.t);
  return kernel;
}

Eigen::VectorXd laplace_beltrami_eigenvalues(const Eigen::VectorXd& eigenvalues, double t, int* undefined, const KernelCut& kernel) {
  require_positive("laplace_beltrami_eigenvalues: t", t);
  if (kernel.dimension != 1 && kernel.dimension != 2)
    throw Error("laplace_beltrami_eigenvalues: the kernel's dimension must be 1 or 2, got " + std::to_string(kernel.dimension));
  if (!(kernel.k > 0)) throw Error("laplace_beltrami_eigenvalues: the kernel's cut k must be > 0");
  const CutKernelSymbol F(kernel);
  Eigen::VectorXd mu(eigenvalues.size());
  int count = 0;
  for (Eigen::Index k = 0; k < eigenvalues.size(); ++k) {
    const double x = eigenvalues[k] * t;
    double a = x < 1 ? -std::log1p(-x) : 0;  // the whole Gaussian's answer; log1p: exact for the small x of the low modes
    bool defined = x < F.mass();
    // F(a) <= 1 - e^(-a) (its tail is >= 0), so the root is at or above the whole Gaussian's, and
    // F' = e^(-a) (1 + O(tail)): Newton's steps with that slope converge by a factor of about the
    // tail's share, 1.2e-3 at k = 6, a step (four or five steps to rounding).
    for (int iteration = 0; defined && !F.whole() && x > 0; ++iteration) {
      const double step = (x - F(a)) * std::exp(a);
      a += step;
      if (!std::isfinite(a) || iteration == 100) defined = false;
      if (std::abs(step) <= 1e-15 * a) break;
    }
    if (!defined) {
      mu[k] = std::numeric_limits<double>::infinity();
      ++count;
    } else {
      mu[k] = a / t;
    }
  }
  if (undefined) *undefined = count;
  return mu;
}

Eigen::MatrixXd heat_kernel_signature(const Spectrum& s, const std::vector<double>& times) {
  const bool estimates = s.laplace_beltrami.size() == s.eigenvalues.size();
  const Eigen::VectorXd& lambda = estimates ? s.laplace_beltrami : s.eigenvalues;
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(s.eigenvectors.rows(), static_cast<Eigen::Index>(times.size()));
  for (std::size_t c = 0; c < times.size(); ++c) {
    require_positive("heat_kernel_signature: the time tau", times[c]);
    for (Eigen::Index k = 0; k < lambda.size(); ++k) {
      const double decay = std::exp(-std::max(lambda[k], 0.0) * times[c]);  // lambda_0 = 0 up to rounding
      if (decay > 0) out.col(static_cast<Eigen::Index>(c)) += decay * s.eigenvectors.col(k).cwiseAbs2();
    }
  }
  return out;
}

std::vector<double> heat_kernel_signature_times(const Spectrum& s, int count) {
  const bool estimates = s.laplace_beltrami.size() == s.eigenvalues.size();
  const Eigen::VectorXd& lambda = estimates ? s.laplace_beltrami : s.eigenvalues;
  double first = 0, last = 0;
  const double zero = 1e-8 * (lambda.size() > 0 ? std::abs(lambda[lambda.size() - 1]) : 0.0);
  for (Eigen::Index k = 0; k < lambda.size(); ++k)
    if (std::isfinite(lambda[k]) && lambda[k] > zero) {
      if (first == 0) first = lambda[k];
      last = lambda[k];
    }
  if (!(first > 0)) throw Error("heat_kernel_signature_times: the spectrum has no non-zero eigenvalue");
  if (count < 1) throw Error("heat_kernel_signature_times: count must be >= 1");
  const double lo = std::log(4 * std::log(10.0) / last), hi = std::log(4 * std::log(10.0) / first);
  std::vector<double> times(static_cast<std::size_t>(count));
  for (int c = 0; c < count; ++c) times[static_cast<std::size_t>(c)] = std::exp(count == 1 ? hi : lo + (hi - lo) * c / (count - 1));
  return times;
}

namespace {

// The rows of one part as a compressed matrix of its own, columns renumbered by `local` (the
// position of each row in its part). Parts are unions of components: no entry leaves them.
SparseMatrix part_of(const SparseMatrix& A, const std::vector<Eigen::Index>& rows, const std::vector<Eigen::Index>& local) {
  const auto n = static_cast<Eigen::Index>(rows.size());
  Eigen::Index nonzeros = 0;
  for (Eigen::Index r : rows) nonzeros += A.outerIndexPtr()[r + 1] - A.outerIndexPtr()[r];
  SparseMatrix part(n, n);
  part.resizeNonZeros(nonzeros);
  int* outer = part.outerIndexPtr();
  outer[0] = 0;
  Eigen::Index k = 0;
  for (Eigen::Index r = 0; r < n; ++r) {
    for (int e = A.outerIndexPtr()[rows[r]]; e < A.outerIndexPtr()[rows[r] + 1]; ++e, ++k) {
      part.innerIndexPtr()[k] = static_cast<int>(local[A.innerIndexPtr()[e]]);  // ascending: local is monotone
      part.valuePtr()[k] = A.valuePtr()[e];
    }
    outer[r + 1] = static_cast<int>(k);
  }
  return part;
}

// Spectra's shift-and-invert Lanczos for the `count` smallest eigenpairs of one part.
// The order of the first non-zero eigenvalue, as 2 pi / (sum mu)^(1/d) squared: (2 pi / P)^2 on
// a closed curve of length P, 4 pi / area times pi on a surface (the unit sphere's is 2 against
// pi), so that shifts and margins scale with the spectrum whatever the units of mu.
double first_eigenvalue_root(const Eigen::VectorXd& mass, int dimension) {
  const double S = mass.sum();
  return 2 * kPi / (dimension == 1 ? S : std::pow(S, 1.0 / dimension));
}

Spectrum lanczos(ShiftInvertOp& op, const Eigen::VectorXd& mass, int count, const SpectrumOptions& o) {
  const Eigen::Index n = mass.size();
  // A shift just below 0: -A - sigma M is then definite, and the eigenvalue 0 of each part stays
  // well separated from the shift relative to the first non-zero one.
  const double root = first_eigenvalue_root(mass, o.dimension);
  const double sigma = -1e-2 * root * root;
  const int ncv = static_cast<int>(std::min<Eigen::Index>(n, o.subspace > 0 ? o.subspace : std::max(2 * count + 1, 20)));
  if (ncv <= count)
    throw Error("smallest_eigenpairs: the subspace size must exceed count");
  MassOp bop(mass);
  Spectra::SymGEigsShiftSolver<ShiftInvertOp, MassOp, Spectra::GEigsMode::ShiftInvert> eigs(op, bop, count, ncv, sigma);
  eigs.init();
  const Eigen::Index converged =
      eigs.compute(Spectra::SortRule::LargestMagn, o.max_iterations, o.tolerance, Spectra::SortRule::SmallestAlge);
  detail::require_converged(eigs, converged, count, ncv);
  Spectrum s;
  s.eigenvalues = eigs.eigenvalues();
  s.eigenvectors = eigs.eigenvectors();
  s.iterations = static_cast<int>(eigs.num_iterations());
  s.operations = static_cast<int>(eigs.num_operations());
  return s;
}

// Y = C X with C = S (-A) S, S = M^-1/2, for a block X: one pass over A for all columns
// (Eigen's sparse * dense product reads A once per column), rows in parallel, each row summed
// in a fixed order whatever the threads.
void symmetric_block_product(const SparseMatrix& A, const Eigen::VectorXd& s, const detail::BlockIn& x, detail::BlockOut y) {
  using RowBlock = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const RowBlock sx = s.asDiagonal() * x;
  RowBlock sy(x.rows(), x.cols());
  const int* outer = A.outerIndexPtr();
  const int* inner = A.innerIndexPtr();
  const double* value = A.valuePtr();
  const Eigen::Index b = x.cols();
#pragma omp parallel for schedule(static, 256)
  for (Eigen::Index i = 0; i < A.rows(); ++i) {
    double* out = sy.row(i).data();
    for (Eigen::Index c = 0; c < b; ++c) out[c] = 0;
    for (int e = outer[i]; e < outer[i + 1]; ++e) {
      const double a = value[e];
      const double* in = sx.row(inner[e]).data();
      for (Eigen::Index c = 0; c < b; ++c) out[c] -= a * in[c];
    }
  }
  y = s.asDiagonal() * sy;
}

// The `count` smallest eigenpairs of one connected part by block LOBPCG on C = S (-A) S with
// products only. The heat-kernel operator's spectrum stops near 1 / t, so LOBPCG converges
// without a preconditioner when the wanted eigenvalues are not too far below it (surfaces,
// where the factorization fills in); on a fine curve it would need hundreds of iterations.
// So it runs within `flops_budget` (the factorization's cost) and returns false when that or
// the memory limit is not enough: the caller then factorizes.
bool lobpcg_spectrum(const SparseMatrix& A, const Eigen::VectorXd& mass, int count, const SpectrumOptions& o,
                     double flops_budget, Spectrum& out) {
  const Eigen::Index n = mass.size();
  const Eigen::Index block = detail::lobpcg_block(n, count);
  const double flops_per_iteration = 2.0 * static_cast<double>(A.nonZeros()) * static_cast<double>(block);
  const int iterations = static_cast<int>(std::min<double>(o.max_iterations, flops_budget / flops_per_iteration));
  if (block >= n / 2 || iterations < 20 || detail::lobpcg_bytes(n, block) > o.memory_limit_bytes) return false;
  const Eigen::VectorXd s = mass.cwiseSqrt().cwiseInverse();
  // Gershgorin: the eigenvalues of C lie in [0, 2 max |A_ii| / m_i]; tolerance relative to it.
  const double c = 2.0 * (A.diagonal().cwiseAbs().array() / mass.array()).maxCoeff();
  const detail::LobpcgResult r = detail::lobpcg(
      [&](const detail::BlockIn& x, detail::BlockOut y) { symmetric_block_product(A, s, x, y); },
      [](const detail::BlockIn& x, detail::BlockOut y) { y = x; }, detail::lobpcg_start(n, block), count, o.tolerance * c,
      iterations, o.progress);
  if (!r.converged) return false;
  out.eigenvalues = r.values;
  out.eigenvectors = s.asDiagonal() * r.vectors;  // M-orthonormal
  out.iterations = r.iterations;
  out.operations = r.products;
  detail::fix_signs(out.eigenvectors);
  return true;
}

// The `count` smallest eigenpairs of one connected part (its kernel is its constants: simple).
// Small parts are solved densely. Larger ones by Lanczos, whose answer is then checked by the
// inertia: had it skipped a copy of a repeated eigenvalue, more eigenvalues than it returned
// would lie below its last one. It is then asked for more; the dense solver is the last resort.
Spectrum connected_spectrum(const SparseMatrix& A, const Eigen::VectorXd& mass, int count, const SpectrumOptions& o) {
  const Eigen::Index n = mass.size();
  constexpr Eigen::Index kDenseLastResort = 3000;
  if (n <= detail::kDenseRows || 2 * count + 1 > n) {
    if (n > kDenseLastResort)
      throw Error("smallest_eigenpairs: " + std::to_string(count) + " eigenpairs of a part of " + std::to_string(n) +
                  " rows is more than half of them; ask for fewer");
    return detail::dense_spectrum(Eigen::MatrixXd(A), mass, count);
  }
  // Products first when asked (surfaces, whose factorization fills in), or when the
  // factorization would cost more than LOBPCG needs: it gets the flops of one factorization (the
  // path below takes at least two, the shift and the inertia check). Surfaces converge in 21-34
  // iterations from h = 0.1 to 0.02; fine curves would need hundreds and are factorized.
  std::unique_ptr<ShiftInvertOp> op;
  if (o.method == SpectrumMethod::Products || (o.method == SpectrumMethod::Auto && o.dimension >= 2)) {
    if (Spectrum s; lobpcg_spectrum(A, mass, count, o, std::numeric_limits<double>::infinity(), s)) return s;
    op = std::make_unique<ShiftInvertOp>(A, mass);
  } else {
    op = std::make_unique<ShiftInvertOp>(A, mass);
    if (Spectrum s; o.method == SpectrumMethod::Auto && lobpcg_spectrum(A, mass, count, o, op->factorization_flops(), s))
      return s;
  }
  // Memory first (issue 25: 5000 eigenpairs of 20,036 surfels took 2.9 GB unannounced): the
  // factor, Lanczos's basis of ncv vectors and the eigenvectors, against the limit.
  const double ncv = static_cast<double>(std::min<Eigen::Index>(n, o.subspace > 0 ? o.subspace : std::max(2 * count + 1, 20)));
  const double lanczos_bytes = op->bytes() + 2.0 * 8.0 * static_cast<double>(n) * (ncv + count);
  if (lanczos_bytes > o.memory_limit_bytes) {
    const Eigen::Index block = detail::lobpcg_block(n, count);
    std::ostringstream msg;
    msg << "smallest_eigenpairs: " << count << " eigenpairs of a part of " << n << " rows need about " << lanczos_bytes / 1e9
        << " GB (factorization and Lanczos)";
    if (block < n / 2) msg << " or " << detail::lobpcg_bytes(n, block) / 1e9 << " GB (LOBPCG)";
    msg << ", above the memory limit of " << o.memory_limit_bytes / 1e9 << " GB; ask for fewer eigenpairs or raise the limit";
    throw Error(msg.str());
  }
  int asked = count;
  for (int attempt = 0; attempt < 3 && 2 * asked + 1 <= n; ++attempt) {
    Spectrum s = lanczos(*op, mass, asked, o);
    // Just above the count-th eigenvalue (far above Lanczos's accuracy, far below the splits
    // of the pairs of a closed curve), relative to the first non-zero scale (2 pi / P)^2.
    const double scale = std::pow(first_eigenvalue_root(mass, o.dimension), 2);
    const double sigma = s.eigenvalues[count - 1] + 1e-8 * std::max(s.eigenvalues[count - 1], scale);
    const Eigen::Index returned = (s.eigenvalues.array() < sigma).count();
    const Eigen::Index below = op->eigenvalues_below(sigma);
    if (below >= 0 && below <= returned) {
      s.eigenvalues.conservativeResize(count);
      s.eigenvectors.conservativeResize(Eigen::NoChange, count);
      detail::fix_signs(s.eigenvectors);
      return s;
    }
    asked = static_cast<int>(std::max<Eigen::Index>(asked + 1, below + 2));
  }
  if (n > kDenseLastResort) {
    std::ostringstream msg;
    msg << "smallest_eigenpairs: Lanczos keeps skipping copies of a repeated eigenvalue in a part of " << n
        << " rows (the inertia of -A - sigma M counts more eigenvalues than it returns); ask for fewer eigenpairs";
    throw Error(msg.str());
  }
  return detail::dense_spectrum(Eigen::MatrixXd(A), mass, count);
}

// Solves each part (in parallel when there are several) and merges them. `count_of_part`
// gives how many pairs each part must provide.
template <class CountOfPart>
std::vector<detail::SpectrumPart> solve_parts(const SparseMatrix& A, const Eigen::VectorXd& mass,
                                              std::vector<std::vector<Eigen::Index>> rows_of_part,
                                              CountOfPart&& count_of_part, const SpectrumOptions& o) {
  std::vector<Eigen::Index> local(static_cast<std::size_t>(mass.size()));
  for (const auto& rows : rows_of_part)
    for (std::size_t r = 0; r < rows.size(); ++r) local[rows[r]] = static_cast<Eigen::Index>(r);
  std::vector<detail::SpectrumPart> parts(rows_of_part.size());
  std::vector<std::exception_ptr> failure(parts.size());
  const auto count = static_cast<Eigen::Index>(parts.size());
#pragma omp parallel for schedule(dynamic) if (count > 1)
  for (Eigen::Index p = 0; p < count; ++p) {
    // Parts side by side: this thread's own count set to 1. Otherwise Eigen, which sizes its
    // product blocking by omp_get_max_threads() (still the outer count inside a nested, serial
    // region), sums as for two threads while it runs on one, and the last bits of every part
    // then depend on the thread count (issue 25): with it, each part gives the bits of a
    // one-thread run. A lone part keeps every thread for its own parallel loops.
    if (omp_get_num_threads() > 1) omp_set_num_threads(1);
    try {
      detail::SpectrumPart& part = parts[p];
      part.rows = std::move(rows_of_part[p]);
      Eigen::VectorXd part_mass(static_cast<Eigen::Index>(part.rows.size()));
      for (std::size_t r = 0; r < part.rows.size(); ++r) part_mass[static_cast<Eigen::Index>(r)] = mass[part.rows[r]];
      part.spectrum = connected_spectrum(part_of(A, part.rows, local), part_mass, count_of_part(part.rows.size()), o);
    } catch (...) {
      failure[p] = std::current_exception();
    }
  }
  for (const auto& f : failure)
    if (f) std::rethrow_exception(f);
  return parts;
}

void check_sizes(const SparseMatrix& A, const Eigen::VectorXd& mass) {
  if (A.rows() != mass.size() || A.cols() != mass.size())
    throw Error("smallest_eigenpairs: A is " + std::to_string(A.rows()) + "x" + std::to_string(A.cols()) +
                " but there are " + std::to_string(mass.size()) + " masses");
}

// The support of mu: the rows with mass, and the index of each row in it (-1 off it).
struct Support {
  std::vector<Eigen::Index> rows;
  std::vector<Eigen::Index> local;
  bool whole() const { return rows.size() == local.size(); }
  Eigen::Index massless() const { return static_cast<Eigen::Index>(local.size() - rows.size()); }
};

Support support_of(const Eigen::VectorXd& mass) {
  detail::check_masses(mass);
  Support s;
  s.local.assign(static_cast<std::size_t>(mass.size()), -1);
  for (Eigen::Index i = 0; i < mass.size(); ++i)
    if (mass[i] > 0) s.local[i] = static_cast<Eigen::Index>(s.rows.size()), s.rows.push_back(i);
  return s;
}

// The rows and columns of A on the support, renumbered (columns stay ascending).
SparseMatrix restricted(const SparseMatrix& A, const Support& support) {
  const auto n = static_cast<Eigen::Index>(support.rows.size());
  Eigen::Index nonzeros = 0;
  for (Eigen::Index r : support.rows)
    for (int e = A.outerIndexPtr()[r]; e < A.outerIndexPtr()[r + 1]; ++e) nonzeros += support.local[A.innerIndexPtr()[e]] >= 0;
  SparseMatrix out(n, n);
  out.resizeNonZeros(nonzeros);
  out.outerIndexPtr()[0] = 0;
  Eigen::Index k = 0;
  for (Eigen::Index r = 0; r < n; ++r) {
    const Eigen::Index row = support.rows[r];
    for (int e = A.outerIndexPtr()[row]; e < A.outerIndexPtr()[row + 1]; ++e) {
      const Eigen::Index c = support.local[A.innerIndexPtr()[e]];
      if (c < 0) continue;
      out.innerIndexPtr()[k] = static_cast<int>(c);
      out.valuePtr()[k++] = A.valuePtr()[e];
    }
    out.outerIndexPtr()[r + 1] = static_cast<int>(k);
  }
  return out;
}

Eigen::VectorXd restricted(const Eigen::VectorXd& v, const Support& support) {
  Eigen::VectorXd out(static_cast<Eigen::Index>(support.rows.size()));
  for (std::size_t r = 0; r < support.rows.size(); ++r) out[static_cast<Eigen::Index>(r)] = v[support.rows[r]];
  return out;
}

// Eigenvectors on the support put back on every row (0 off the support).
void embed(Spectrum& s, const Support& support) {
  Eigen::MatrixXd full = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(support.local.size()), s.eigenvectors.cols());
  for (std::size_t r = 0; r < support.rows.size(); ++r) full.row(support.rows[r]) = s.eigenvectors.row(static_cast<Eigen::Index>(r));
  s.eigenvectors = std::move(full);
  s.massless = support.massless();
}

// The spectrum of (A, mass), with support.rows all the rows (no restriction) or not.
Spectrum spectrum_on_support(const SparseMatrix& A, const Eigen::VectorXd& mass, const Support& support, const SpectrumOptions& o) {
  detail::check_solver_options(o.tolerance, o.max_iterations);
  detail::check_count(static_cast<Eigen::Index>(support.rows.size()), support.massless(), o.count);
  auto solve = [&](const SparseMatrix& a, const Eigen::VectorXd& m) {
    // Part by part: the connected components of A (one per contour in geodesic mode).
    const auto parts = solve_parts(a, m, detail::connected_components(a).rows,
                                   [&](std::size_t rows) { return static_cast<int>(std::min<std::size_t>(o.count, rows)); }, o);
    return detail::merge_parts(parts, m.size(), o.count);
  };
  if (support.whole()) return solve(A, mass);
  Spectrum s = solve(restricted(A, support), restricted(mass, support));
  embed(s, support);
  return s;
}

// Each zero-mass row of the columns of `vectors` (on the operator's rows) set to the heat-kernel
// average of its neighbours: u_i = sum_{j != i} L_ij u_j / (-L_ii), where every L_ij != 0 has
// mass (L_ij = w_ij mu_j), so the order of the rows does not matter.
void fill_massless(const HeatOperator& op, const std::vector<Eigen::Index>& massless, Eigen::MatrixXd& vectors) {
  for (Eigen::Index i : massless) {
    Eigen::RowVectorXd sum = Eigen::RowVectorXd::Zero(vectors.cols());
    double diagonal = 0;
    for (SparseMatrix::InnerIterator it(op.L, i); it; ++it) {
      if (it.col() == i) diagonal = it.value();
      else sum += it.value() * vectors.row(it.col());
    }
    vectors.row(i) = sum / -diagonal;
  }
}

void require_stiffness(const HeatOperator& op, const char* who) {
  if (op.A.rows() != op.rows() || op.mass.size() != op.rows())
    throw Error(std::string(who) + ": the operator has no stiffness A (assembled with stiffness = false) or no masses");
}

}  // namespace

Spectrum smallest_eigenpairs(const SparseMatrix& A, const Eigen::VectorXd& mass, const SpectrumOptions& o) {
  check_sizes(A, mass);
  return spectrum_on_support(A, mass, support_of(mass), o);
}

Spectrum smallest_eigenpairs(const HeatOperator& op, const SpectrumOptions& options) {
  require_stiffness(op, "smallest_eigenpairs");
  SpectrumOptions o = options;
  o.dimension = op.dimension;
  const Support support = support_of(op.mass);
  const std::vector<Eigen::Index> massless = op.massless_rows();
  detail::check_massless_reach_mass(op, massless, "smallest_eigenpairs");
  Spectrum s = spectrum_on_support(op.A, op.mass, support, o);
  if (!massless.empty()) {
    fill_massless(op, massless, s.eigenvectors);
    detail::fix_signs(s.eigenvectors);
  }
  if (op.t <= 0) return s;
  // Per part when their times differ (geodesic: each eigenvector lives on one contour; with
  // the Euclidean distance all contours share one t).
  std::vector<double> part_t(op.parts());
  for (std::size_t p = 0; p < part_t.size(); ++p) part_t[p] = op.time_of_part(p);
  if (part_t.empty()) {  // an operator built by hand
    const std::vector<Eigen::Index> whole{0, op.rows()};
    detail::laplace_beltrami_by_contour(s, whole, {op.t}, kernel_cut_of(op));
  } else {
    detail::laplace_beltrami_by_contour(s, op.row_offset, part_t, kernel_cut_of(op));
  }
  return s;
}

std::vector<Spectrum> smallest_eigenpairs_per_part(const HeatOperator& op, const SpectrumOptions& options) {
  require_stiffness(op, "smallest_eigenpairs_per_part");
  if (options.count < 1) throw Error("smallest_eigenpairs_per_part: count must be >= 1, got " + std::to_string(options.count));
  SpectrumOptions o = options;
  o.dimension = op.dimension;
  const Support support = support_of(op.mass);
  std::vector<Eigen::Index> offset = op.row_offset;  // the parts' rows, on the support
  if (offset.empty()) offset = {0, op.rows()};
  const std::size_t part_count = offset.size() - 1;
  std::vector<Eigen::Index> support_offset(offset.size(), 0);
  std::vector<Eigen::Index> massless;  // of the parts with mass: a part with none has an empty spectrum
  for (std::size_t p = 0; p < part_count; ++p) {
    Eigen::Index with_mass = 0;
    for (Eigen::Index r = offset[p]; r < offset[p + 1]; ++r) with_mass += support.local[r] >= 0;
    support_offset[p + 1] = support_offset[p] + with_mass;
    if (with_mass > 0)
      for (Eigen::Index r = offset[p]; r < offset[p + 1]; ++r)
        if (support.local[r] < 0) massless.push_back(r);
  }
  detail::check_massless_reach_mass(op, massless, "smallest_eigenpairs_per_part");
  const SparseMatrix A = support.whole() ? SparseMatrix() : restricted(op.A, support);
  const SparseMatrix& a = support.whole() ? op.A : A;
  const Eigen::VectorXd mass = restricted(op.mass, support);
  const detail::Components components = detail::connected_components(a);
  std::vector<std::vector<Eigen::Index>> rows_of_part;  // the components, grouped by part
  std::vector<std::size_t> part_of_component;
  for (std::size_t p = 0; p < part_count; ++p) {
    for (Eigen::Index r = support_offset[p]; r < support_offset[p + 1]; ++r) {
      const auto& rows = components.rows[components.of_row[r]];
      if (rows.front() < support_offset[p] || rows.back() >= support_offset[p + 1])
        throw Error("smallest_eigenpairs_per_part: part " + std::to_string(p) +
                    " interacts with another one (contours at the Euclidean distance): a spectrum per part needs parts "
                    "that do not (the geodesic operator)");
      if (rows.front() == r) {
        rows_of_part.push_back(rows);
        part_of_component.push_back(p);
      }
    }
  }
  const auto parts = solve_parts(a, mass, std::move(rows_of_part),
                                 [&](std::size_t rows) { return static_cast<int>(std::min<std::size_t>(o.count, rows)); }, o);
  std::vector<Spectrum> spectra;
  for (std::size_t p = 0; p < part_count; ++p) {
    std::vector<detail::SpectrumPart> of_part;
    for (std::size_t c = 0; c < parts.size(); ++c)
      if (part_of_component[c] == p) {
        of_part.push_back(parts[c]);
        for (Eigen::Index& r : of_part.back().rows) r -= support_offset[p];
      }
    const Eigen::Index n = support_offset[p + 1] - support_offset[p], rows = offset[p + 1] - offset[p];
    if (n == 0) {  // no mass at all: no eigenpair, every row off the support
      Spectrum none;
      none.eigenvectors.resize(rows, 0);
      none.massless = rows;
      spectra.push_back(std::move(none));
      continue;
    }
    Spectrum s = detail::merge_parts(of_part, n, static_cast<int>(std::min<Eigen::Index>(o.count, n)));
    if (n < rows) {  // back on the part's own rows, zero-mass rows from their row of L
      Eigen::MatrixXd full = Eigen::MatrixXd::Zero(op.rows(), s.eigenvectors.cols());
      for (Eigen::Index r = 0; r < n; ++r) full.row(support.rows[support_offset[p] + r]) = s.eigenvectors.row(r);
      std::vector<Eigen::Index> own_massless;
      for (Eigen::Index i : massless)
        if (i >= offset[p] && i < offset[p + 1]) own_massless.push_back(i);
      fill_massless(op, own_massless, full);
      s.eigenvectors = full.middleRows(offset[p], rows);
      s.massless = rows - n;
      detail::fix_signs(s.eigenvectors);
    }
    const double t_p = op.time_of_part(p);
    if (t_p > 0) s.laplace_beltrami = laplace_beltrami_eigenvalues(s.eigenvalues, t_p, &s.undefined_estimates, kernel_cut_of(op));
    spectra.push_back(std::move(s));
  }
  return spectra;
}

}  // namespace digilap
