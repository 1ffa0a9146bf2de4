// digilap — what every heat-kernel Laplacian is, whatever the dimension (core).
//
// A contour operator (curves, d = 1, curve/heat_laplacian.hpp) and a surface operator (surfaces,
// d = 2, surface/heat_laplacian.hpp) are both a HeatOperator: the Laplacian L (approximates
// +Laplace-Beltrami, negative semidefinite, rows summing to 0, L_ij = w_ij mu_j >= 0), the
// symmetric stiffness A = M L, the mass matrix M = diag(mu), the heat time t and the kernel's
// cut, with rows grouped in parts (contours, connected surfaces) by row_offset. Everything
// downstream (spectra, heat flow, smoothing, files) takes a HeatOperator and is written once.
//
// Elements of measure mu = 0 (an II normal orthogonal to its element: thin parts, long straight
// steps) have vanishing rows and columns in A: the pair (A, M) lives on the support of mu. The
// downstream functions solve there and give such an element the heat-kernel average of its
// neighbours, its row of L: u_i = sum_{j != i} L_ij u_j / sum_{j != i} L_ij.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <cstddef>
#include <string>
#include <vector>

namespace digilap {

/// Compressed row storage: rows are assembled in parallel, and Eigen multiplies RowMajor
/// matrices by vectors in parallel. Assigning to a default (ColMajor) Eigen::SparseMatrix converts.
using SparseMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor, int>;

struct HeatOperator {
  SparseMatrix L;        ///< the Laplacian (approximates +Laplace-Beltrami)
  SparseMatrix A;        ///< the symmetric stiffness M L (empty when assembled without it)
  SparseMatrix M;        ///< the diagonal mass matrix diag(mu)
  Eigen::VectorXd mass;  ///< mu of each element (the diagonal of M): lengths (d = 1), areas (d = 2)
  /// The manifold's dimension d: 1 for contours, 2 for surfaces. It sets the kernel's prefactor
  /// 1 / (t (4 pi t)^(d/2)) and the scale of the spectrum, lambda_1 ~ (2 pi)^2 / (sum mu)^(2/d).
  int dimension = 1;
  /// Heat time (0 for the DEC baselines); with per-part times, that of the part with the most rows.
  double t = 0.0;
  double length_scale = 0.0;  ///< l behind t (0 when t was given)
  double cut = 0.0;           ///< kernel cut distance k sqrt(t) (0 for the DEC baselines)
  /// Rows of part p (a contour, or a surface): [row_offset[p], row_offset[p + 1]).
  std::vector<Eigen::Index> row_offset;
  /// Heat time of each part: all equal to t unless the parts have their own (contours in
  /// geodesic mode); empty for the DEC baselines.
  std::vector<double> part_t;

  Eigen::Index rows() const { return L.rows(); }
  std::size_t parts() const { return row_offset.empty() ? 0 : row_offset.size() - 1; }
  /// The heat time of part p: part_t[p], or t when part_t does not have one per part.
  double time_of_part(std::size_t p) const { return part_t.size() == parts() ? part_t[p] : t; }
  /// Rows whose mass is 0 (ascending): see the note on zero measures above.
  std::vector<Eigen::Index> massless_rows() const;
};

/// Bytes a heat Laplacian would take (L, and A unless `stiffness` is false, in compressed
/// storage; M and the element arrays), for a given number of nonzeros per matrix and of rows.
double heat_laplacian_bytes(std::size_t nonzeros, std::size_t rows, bool stiffness = true);

namespace detail {
/// M = diag(mass), in compressed storage: the mass matrix of every operator.
SparseMatrix diagonal_matrix(const Eigen::VectorXd& mass);
/// The one memory check of every assembled operator, before anything is allocated: refuses an
/// estimated size above `limit` bytes, or 2^31 nonzeros or more (the compressed rows' offsets are
/// int). `who` starts the message ("heat_laplacian", "heat_laplacian (surfaces)"); `advice`
/// ends it with what helps in the caller's setting.
void check_operator_memory(const std::string& who, std::size_t nonzeros, std::size_t rows, double limit, bool stiffness,
                           const std::string& advice);
}  // namespace detail

}  // namespace digilap
