// Spectra of the matrix-free contour operator: per contour, by Spectra on the symmetric form
// with an arclength preconditioner or LOBPCG, merged across contours (core/spectrum_parts.hpp).
#include "digilap/curve/matrix_free.hpp"

#include "digilap/core/constants.hpp"
#include "digilap/core/error.hpp"
#include "core/eigen_checks.hpp"
#include "core/lobpcg.hpp"
#include "core/spectrum_parts.hpp"
#include "cyclic_tridiagonal.hpp"

#include <Spectra/SymEigsSolver.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>

namespace digilap {
inline namespace curve {

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
  void apply_block(const detail::BlockIn& x, detail::BlockOut y) const {
    scaled_.resize(x.rows(), x.cols());  // blocks reused by every call (y is LOBPCG's view)
    const double* s = sqrt_mass_.data();
#pragma omp parallel for schedule(static)
    for (Eigen::Index k = 0; k < x.cols(); ++k)
      for (Eigen::Index i = 0; i < n_; ++i) scaled_(i, k) = x(i, k) / s[i];
    op_.apply_contour_block(contour_, scaled_, product_);
#pragma omp parallel for schedule(static)
    for (Eigen::Index k = 0; k < y.cols(); ++k)
      for (Eigen::Index i = 0; i < n_; ++i) y(i, k) = product_(i, k) * -s[i];
  }

private:
  const MatrixFreeLaplacian& op_;
  std::size_t contour_;
  Eigen::Index first_, n_;
  Eigen::VectorXd sqrt_mass_;
  mutable Eigen::VectorXd z_, w_;
  mutable Eigen::MatrixXd scaled_, product_;
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
  void apply_block(const detail::BlockIn& r, detail::BlockOut out) const {
    const Eigen::Index n = r.rows();
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
  const Eigen::Index block = detail::lobpcg_block(n, count);
  // LOBPCG's blocks, and the form's scaled copy of the block it multiplies and its product.
  const double lobpcg_need = detail::lobpcg_bytes(n, block) + 16.0 * static_cast<double>(n) * static_cast<double>(block);
  if (block < n / 2 && lobpcg_need <= o.memory_limit_bytes) {
    const ArclengthPreconditioner preconditioner(op, contour);
    const detail::LobpcgResult r = detail::lobpcg(
        [&](const detail::BlockIn& x, detail::BlockOut y) { form.apply_block(x, y); },
        [&](const detail::BlockIn& x, detail::BlockOut y) { preconditioner.apply_block(x, y); },
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


Spectrum smallest_eigenpairs(const MatrixFreeLaplacian& op, const SpectrumOptions& o) {
  detail::check_solver_options(o.tolerance, o.max_iterations);
  detail::check_eigen_request(op.mass(), o.count);
  // Contour by contour (the operator is block-diagonal by contour), then merged: repeated
  // eigenvalues of identical contours are all counted (spectrum_parts.hpp).
  Spectrum s = detail::merge_parts(contour_parts(op, o.count, o), op.rows(), o.count);
  detail::laplace_beltrami_by_contour(s, op.row_offset(), op.contour_t(), KernelCut{1, op.cut() / std::sqrt(op.t())});
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
                                                                   &spectra.back().undefined_estimates,
                                                                   KernelCut{1, op.cut() / std::sqrt(op.t())});
  }
  return spectra;
}

}  // namespace curve
}  // namespace digilap
