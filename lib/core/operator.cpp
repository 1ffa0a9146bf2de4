#include "digilap/core/operator.hpp"

#include "digilap/core/error.hpp"
#include "massless.hpp"

#include <algorithm>
#include <limits>
#include <sstream>

namespace digilap {

std::vector<Eigen::Index> HeatOperator::massless_rows() const {
  std::vector<Eigen::Index> rows;
  for (Eigen::Index i = 0; i < mass.size(); ++i)
    if (!(mass[i] > 0)) rows.push_back(i);
  return rows;
}

double heat_laplacian_bytes(std::size_t nonzeros, std::size_t rows, bool stiffness) {
  // L and A: values (8) + column indices (4) per nonzero, row offsets (4) per row; M: 12 per row;
  // plus the element arrays (positions, mu, arclength: 32 per row).
  return (stiffness ? 2.0 : 1.0) * (12.0 * nonzeros + 4.0 * (rows + 1)) + 12.0 * rows + 32.0 * rows;
}

namespace detail {
void check_operator_memory(const std::string& who, std::size_t nonzeros, std::size_t rows, double limit, bool stiffness,
                           const std::string& advice) {
  if (!(limit > 0))  // NaN compares false everywhere: it would disable the check silently
    throw Error(who + ": the memory limit must be > 0 bytes (infinity for none), got " + std::to_string(limit));
  const double bytes = heat_laplacian_bytes(nonzeros, rows, stiffness);
  const bool too_many = nonzeros > static_cast<std::size_t>(std::numeric_limits<int>::max());
  if (bytes <= limit && !too_many) return;
  std::ostringstream msg;
  msg << who << ": the operator would take about " << bytes / 1e9 << " GB (" << nonzeros << " nonzeros per matrix, "
      << rows << " rows), ";
  if (too_many)
    msg << "2^31 nonzeros or more, which compressed rows with int offsets cannot hold; " << advice;
  else
    msg << "above the memory limit of " << limit / 1e9 << " GB; raise memory_limit_bytes, or " << advice;
  throw Error(msg.str());
}
void check_massless_reach_mass(const HeatOperator& op, const std::vector<Eigen::Index>& massless, const char* who) {
  for (Eigen::Index i : massless) {
    if (op.L.coeff(i, i) < 0) continue;
    std::string part;
    if (op.parts() > 1) {
      const auto p = static_cast<std::size_t>(std::upper_bound(op.row_offset.begin(), op.row_offset.end(), i) - op.row_offset.begin() - 1);
      part = " of part " + std::to_string(p) + " (" + std::to_string(op.row_offset[p + 1] - op.row_offset[p]) + " rows)";
    }
    throw Error(std::string(who) + ": row " + std::to_string(i) + part +
                " has zero mass and no neighbour with mass within the kernel's cut (a part with no mass at all: every II "
                "normal of it orthogonal to its element, as on a speck of a few voxels); drop it (a minimum size, or the "
                "largest part only), take the spectra per part, or use a smaller k_R");
  }
}
}  // namespace detail

namespace detail {
SparseMatrix diagonal_matrix(const Eigen::VectorXd& mass) {
  const Eigen::Index n = mass.size();
  SparseMatrix M(n, n);
  M.reserve(Eigen::VectorXi::Ones(n));
  for (Eigen::Index r = 0; r < n; ++r) M.insert(r, r) = mass[r];
  M.makeCompressed();
  return M;
}
}  // namespace detail

}  // namespace digilap
