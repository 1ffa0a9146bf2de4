#include "spectrum_parts.hpp"

#include "digilap/core/error.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <numeric>
#include <tuple>

namespace digilap::detail {

void laplace_beltrami_by_contour(Spectrum& s, const std::vector<Eigen::Index>& row_offset,
                                 const std::vector<double>& contour_t, const KernelCut& kernel) {
  s.laplace_beltrami.resize(s.eigenvalues.size());
  s.undefined_estimates = 0;
  for (Eigen::Index k = 0; k < s.eigenvalues.size(); ++k) {
    Eigen::Index row = 0;
    s.eigenvectors.col(k).cwiseAbs().maxCoeff(&row);
    const auto contour = static_cast<std::size_t>(std::upper_bound(row_offset.begin(), row_offset.end(), row) - row_offset.begin() - 1);
    int undefined = 0;
    s.laplace_beltrami[k] = laplace_beltrami_eigenvalues(s.eigenvalues.segment(k, 1), contour_t[contour], &undefined, kernel)[0];
    s.undefined_estimates += undefined;
  }
}

void fix_signs(Eigen::MatrixXd& vectors) {
  for (Eigen::Index k = 0; k < vectors.cols(); ++k) {
    Eigen::Index largest = 0;
    vectors.col(k).cwiseAbs().maxCoeff(&largest);  // the first maximum
    if (vectors(largest, k) < 0) vectors.col(k) = -vectors.col(k);
  }
}

Spectrum merge_parts(const std::vector<SpectrumPart>& parts, Eigen::Index n, int count) {
  std::vector<std::tuple<double, std::size_t, Eigen::Index>> candidates;  // (lambda, part, index)
  Spectrum merged;
  for (std::size_t p = 0; p < parts.size(); ++p) {
    const Spectrum& s = parts[p].spectrum;
    for (Eigen::Index k = 0; k < s.eigenvalues.size(); ++k) candidates.emplace_back(s.eigenvalues[k], p, k);
    merged.iterations += s.iterations;
    merged.operations += s.operations;
  }
  const std::size_t kept = std::min<std::size_t>(candidates.size(), static_cast<std::size_t>(count));
  std::partial_sort(candidates.begin(), candidates.begin() + static_cast<std::ptrdiff_t>(kept), candidates.end());
  merged.eigenvalues.resize(static_cast<Eigen::Index>(kept));
  merged.eigenvectors = Eigen::MatrixXd::Zero(n, static_cast<Eigen::Index>(kept));
  for (std::size_t k = 0; k < kept; ++k) {
    const auto& [lambda, p, index] = candidates[k];
    merged.eigenvalues[static_cast<Eigen::Index>(k)] = lambda;
    const std::vector<Eigen::Index>& rows = parts[p].rows;
    const Eigen::MatrixXd& vectors = parts[p].spectrum.eigenvectors;
    for (std::size_t r = 0; r < rows.size(); ++r)
      merged.eigenvectors(rows[r], static_cast<Eigen::Index>(k)) = vectors(static_cast<Eigen::Index>(r), index);
  }
  fix_signs(merged.eigenvectors);
  return merged;
}

Spectrum dense_spectrum(const Eigen::MatrixXd& A, const Eigen::VectorXd& mass, int count) {
  const Eigen::VectorXd inv_sqrt = mass.cwiseSqrt().cwiseInverse();
  Eigen::MatrixXd C = -(inv_sqrt.asDiagonal() * A * inv_sqrt.asDiagonal());
  C = 0.5 * (C + C.transpose()).eval();  // symmetric to the last bit
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(C);
  if (eig.info() != Eigen::Success) throw Error("smallest_eigenpairs: the dense eigen-decomposition of a part failed");
  const Eigen::Index kept = std::min<Eigen::Index>(count, C.rows());
  Spectrum s;
  s.eigenvalues = eig.eigenvalues().head(kept);
  s.eigenvectors = inv_sqrt.asDiagonal() * eig.eigenvectors().leftCols(kept);
  fix_signs(s.eigenvectors);
  return s;
}

}  // namespace digilap::detail
