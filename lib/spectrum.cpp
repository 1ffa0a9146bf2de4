#include "digilap/spectrum.hpp"

#include "digilap/error.hpp"
#include "components.hpp"
#include "eigen_checks.hpp"
#include "lobpcg.hpp"
#include "spectrum_parts.hpp"

#include <Eigen/SparseCholesky>
#include <Spectra/SymGEigsShiftSolver.h>

#include <cmath>
#include <memory>
#include <limits>
#include <exception>
#include <sstream>

namespace digilap {

namespace {

constexpr double kPi = 3.14159265358979323846;
using ColMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

// Eigen's SimplicialLDLT with the size of its factor, known from the symbolic analysis alone.
class SimplicialLDLT : public Eigen::SimplicialLDLT<ColMatrix> {
public:
  /// Flops of the numeric factorization, sum over columns of (nonzeros below the diagonal)^2.
  double factorization_flops() const { return m_nonZerosPerCol.cast<double>().array().square().sum(); }
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

Eigen::VectorXd laplace_beltrami_eigenvalues(const Eigen::VectorXd& eigenvalues, double t, int* undefined) {
  require_positive("laplace_beltrami_eigenvalues: t", t);
  Eigen::VectorXd mu(eigenvalues.size());
  int count = 0;
  for (Eigen::Index k = 0; k < eigenvalues.size(); ++k) {
    const double x = eigenvalues[k] * t;
    if (x >= 1) {
      mu[k] = std::numeric_limits<double>::infinity();
      ++count;
    } else {
      mu[k] = -std::log1p(-x) / t;  // log1p: exact for the small lambda t of the low modes
    }
  }
  if (undefined) *undefined = count;
  return mu;
}

double heat_kernel_eigenvalue(int m, double P, double t) {
  const double w = 2 * kPi * m / P, w2 = w * w;
  if (t == 0) return w2;
  return -std::expm1(-w2 * t) / t;
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
Spectrum lanczos(ShiftInvertOp& op, const Eigen::VectorXd& mass, int count, const SpectrumOptions& o) {
  const Eigen::Index n = mass.size();
  // A shift just below 0: -A - sigma M is then definite, and the eigenvalue 0 of each contour
  // stays well separated from the shift relative to the first non-zero one (about (2 pi / P)^2).
  const double sigma = -1e-2 * (2 * kPi / mass.sum()) * (2 * kPi / mass.sum());
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
void symmetric_block_product(const SparseMatrix& A, const Eigen::VectorXd& s, const Eigen::MatrixXd& x, Eigen::MatrixXd& y) {
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
  const Eigen::Index block = std::min<Eigen::Index>(n, count + std::max(4, count / 2));
  const double flops_per_iteration = 2.0 * static_cast<double>(A.nonZeros()) * static_cast<double>(block);
  const int iterations = static_cast<int>(std::min<double>(o.max_iterations, flops_budget / flops_per_iteration));
  if (block >= n / 2 || iterations < 20 || detail::lobpcg_bytes(n, block) > o.memory_limit_bytes) return false;
  const Eigen::VectorXd s = mass.cwiseSqrt().cwiseInverse();
  // Gershgorin: the eigenvalues of C lie in [0, 2 max |A_ii| / m_i]; tolerance relative to it.
  const double c = 2.0 * (A.diagonal().cwiseAbs().array() / mass.array()).maxCoeff();
  const detail::LobpcgResult r = detail::lobpcg(
      [&](const Eigen::MatrixXd& x, Eigen::MatrixXd& y) { symmetric_block_product(A, s, x, y); },
      [](const Eigen::MatrixXd& x, Eigen::MatrixXd& y) { y = x; }, detail::lobpcg_start(n, block), count, o.tolerance * c,
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
  if (o.method == SpectrumMethod::Products) {
    if (Spectrum s; lobpcg_spectrum(A, mass, count, o, std::numeric_limits<double>::infinity(), s)) return s;
    op = std::make_unique<ShiftInvertOp>(A, mass);
  } else {
    op = std::make_unique<ShiftInvertOp>(A, mass);
    if (Spectrum s; o.method == SpectrumMethod::Auto && lobpcg_spectrum(A, mass, count, o, op->factorization_flops(), s))
      return s;
  }
  int asked = count;
  for (int attempt = 0; attempt < 3 && 2 * asked + 1 <= n; ++attempt) {
    Spectrum s = lanczos(*op, mass, asked, o);
    // Just above the count-th eigenvalue (far above Lanczos's accuracy, far below the splits
    // of the pairs of a closed curve), relative to the first non-zero scale (2 pi / P)^2.
    const double scale = std::pow(2 * kPi / mass.sum(), 2);
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

}  // namespace

Spectrum smallest_eigenpairs(const SparseMatrix& A, const Eigen::VectorXd& mass, const SpectrumOptions& o) {
  check_sizes(A, mass);
  detail::check_eigen_request(mass, o.count);
  // Part by part: the connected components of A (one per contour in geodesic mode).
  const auto parts = solve_parts(A, mass, detail::connected_components(A).rows,
                                 [&](std::size_t rows) { return static_cast<int>(std::min<std::size_t>(o.count, rows)); }, o);
  return detail::merge_parts(parts, mass.size(), o.count);
}

std::vector<Spectrum> smallest_eigenpairs_per_contour(const ContourOperator& op, const SpectrumOptions& o) {
  check_sizes(op.A, op.mass);
  if (o.count < 1) throw Error("smallest_eigenpairs_per_contour: count must be >= 1, got " + std::to_string(o.count));
  detail::check_eigen_request(op.mass, 1);  // masses > 0
  const detail::Components components = detail::connected_components(op.A);
  std::vector<std::vector<Eigen::Index>> rows_of_part;  // the components, grouped by contour
  std::vector<std::size_t> contour_of_part;
  for (std::size_t c = 0; c + 1 < op.row_offset.size(); ++c) {
    for (Eigen::Index r = op.row_offset[c]; r < op.row_offset[c + 1]; ++r) {
      const auto& rows = components.rows[components.of_row[r]];
      if (rows.front() < op.row_offset[c] || rows.back() >= op.row_offset[c + 1])
        throw Error("smallest_eigenpairs_per_contour: contour " + std::to_string(c) +
                    " interacts with another one (Euclidean distance): a spectrum per contour needs the geodesic operator");
      if (rows.front() == r) {
        rows_of_part.push_back(rows);
        contour_of_part.push_back(c);
      }
    }
  }
  const auto parts = solve_parts(op.A, op.mass, std::move(rows_of_part),
                                 [&](std::size_t rows) { return static_cast<int>(std::min<std::size_t>(o.count, rows)); }, o);
  std::vector<Spectrum> spectra;
  for (std::size_t c = 0; c + 1 < op.row_offset.size(); ++c) {
    std::vector<detail::SpectrumPart> of_contour;
    for (std::size_t p = 0; p < parts.size(); ++p)
      if (contour_of_part[p] == c) {
        of_contour.push_back(parts[p]);
        for (Eigen::Index& r : of_contour.back().rows) r -= op.row_offset[c];
      }
    const Eigen::Index n = op.row_offset[c + 1] - op.row_offset[c];
    spectra.push_back(detail::merge_parts(of_contour, n, static_cast<int>(std::min<Eigen::Index>(o.count, n))));
    const double t_c = op.contour_t.size() + 1 == op.row_offset.size() ? op.contour_t[c] : op.t;
    if (t_c > 0)
      spectra.back().laplace_beltrami =
          laplace_beltrami_eigenvalues(spectra.back().eigenvalues, t_c, &spectra.back().undefined_estimates);
  }
  return spectra;
}

Spectrum smallest_eigenpairs(const ContourOperator& op, const SpectrumOptions& options) {
  Spectrum s = smallest_eigenpairs(op.A, op.mass, options);
  if (op.t <= 0) return s;
  // Per contour when their times differ (geodesic: each eigenvector lives on one contour; with
  // the Euclidean distance all contours share one t).
  const std::vector<double> one_t(op.row_offset.size() - 1, op.t);  // an operator built by hand
  detail::laplace_beltrami_by_contour(s, op.row_offset, op.contour_t.size() + 1 == op.row_offset.size() ? op.contour_t : one_t);
  return s;
}

}  // namespace digilap
