// Internal: a sparse LDL^T factorization (Eigen's SimplicialLDLT, AMD ordering) whose solves
// take a block of right-hand sides 8 at a time: each entry of L is read once for 8 columns and
// applied to all of them in one vector operation. Eigen's solve takes one column after another
// and reads the whole factor for each (a preconditioner's solves were 10% of a surface
// spectrum's time). Each column's arithmetic is the same whatever the columns beside it, so
// results do not depend on how the block is split among threads.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <vector>

namespace digilap::detail {

class BlockLdlt {
public:
  /// Factorizes the symmetric positive definite matrix whose lower triangle is `lower`;
  /// returns false when that fails (not positive definite).
  bool compute(const Eigen::SparseMatrix<double>& lower);
  /// y <- A^(-1) y, column by column, the columns in groups of 8 over the OpenMP threads (in
  /// place: y is often a view of a solver's block, with no room for another).
  void solve_in_place(Eigen::Ref<Eigen::MatrixXd> y) const;

private:
  std::vector<int> start_, row_;  // L's strictly lower entries, column by column
  std::vector<double> value_;
  Eigen::VectorXd inverse_d_;
  std::vector<int> position_;  // row i of the system is row position_[i] of the factor
};

}  // namespace digilap::detail
