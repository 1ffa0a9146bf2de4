#include "components.hpp"

#include <numeric>

namespace digilap::detail {

Components connected_components(const SparseMatrix& A) {
  const Eigen::Index n = A.rows();
  // Union-find with path halving; each root is the smallest row of its tree.
  std::vector<Eigen::Index> parent(static_cast<std::size_t>(n));
  std::iota(parent.begin(), parent.end(), Eigen::Index(0));
  auto root = [&](Eigen::Index i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (Eigen::Index i = 0; i < n; ++i)
    for (SparseMatrix::InnerIterator it(A, i); it; ++it) {
      if (it.col() == i || it.value() == 0) continue;
      const Eigen::Index a = root(i), b = root(it.col());
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
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
