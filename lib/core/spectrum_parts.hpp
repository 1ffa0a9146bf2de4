// Internal: spectra of block-diagonal problems, solved part by part and merged. A problem
// -A x = lambda M x whose graph falls into parts (contours, connected components) has for
// spectrum the union of the parts' spectra, with multiplicities: ten identical contours give
// every eigenvalue ten times. A Krylov or block solver run on the whole sees one copy of an
// eigenvalue per start direction and silently skips the others; part by part, each part's
// eigenvalues are simple or paired, and the merge counts every copy.
#pragma once

#include "digilap/core/spectrum.hpp"

#include <Eigen/Core>

#include <vector>

namespace digilap::detail {

/// Rows of the whole taken by a part (ascending), and the part's spectrum on those rows.
struct SpectrumPart {
  std::vector<Eigen::Index> rows;
  Spectrum spectrum;
};

/// Up to which size a part is solved densely (O(n^3), exact, robust to any multiplicity).
constexpr Eigen::Index kDenseRows = 400;

/// The `count` smallest eigenpairs of the union of the parts, ascending (ties in part order),
/// eigenvectors embedded in `n` rows (zero outside their part), signs fixed; iterations and
/// operations summed over the parts.
Spectrum merge_parts(const std::vector<SpectrumPart>& parts, Eigen::Index n, int count);

/// The `count` smallest eigenpairs of -A x = lambda diag(mass) x, A dense symmetric, through
/// the symmetric form M^(-1/2) (-A) M^(-1/2); M-orthonormal vectors, signs fixed.
Spectrum dense_spectrum(const Eigen::MatrixXd& A, const Eigen::VectorXd& mass, int count);

/// Fills s.laplace_beltrami (and undefined_estimates) when contours have their own heat times:
/// each eigenvector lives on one contour (the operator is block-diagonal by contour), the one of
/// its largest entry, whose time its estimate takes. Rows of contour c are
/// [row_offset[c], row_offset[c + 1]).
void laplace_beltrami_by_contour(Spectrum& s, const std::vector<Eigen::Index>& row_offset,
                                 const std::vector<double>& contour_t, const KernelCut& kernel);

/// A fixed sign for each eigenvector: its entry of largest magnitude (the first, on ties) is
/// positive. The solvers' own sign depends on rounding, hence on the number of threads.
void fix_signs(Eigen::MatrixXd& vectors);

}  // namespace digilap::detail
