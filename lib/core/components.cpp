#include "components.hpp"
#include "union_find.hpp"

#include <numeric>

namespace digilap::detail {

Components connected_components(const SparseMatrix& A) {
  const Eigen::Index n = A.rows();
  UnionFind trees(static_cast<std::size_t>(n));  // each root the smallest row of its tree
  auto root = [&](Eigen::Index i) { return static_cast<Eigen::Index>(trees.root(static_cast<std::size_t>(i))); };
  for (Eigen::Index i = 0; i < n; ++i)
    for (SparseMatrix::InnerIterator it(A, i); it; ++it) {
      if (it.col() == i || it.value() == 0) continue;
      trees.join(static_cast<std::size_t>(i), static_cast<std::size_t>(it.col()));
    }
  Components c;
  c.of_row.assign(static_cast<std::size_t>(n), -1);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Index r = root(i);
    if (r == i) {
      c.of_row[i] = static_cast<int>(c.rows.size());
      c.rows.emplace_back();
    } else {
      c.of_row[i] = c.of_row[r];  // r < i: already numbered
    }
    c.rows[c.of_row[i]].push_back(i);
  }
  return c;
}

}  // namespace digilap::detail
