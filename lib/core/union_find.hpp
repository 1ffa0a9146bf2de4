// Internal: union-find over 0..n-1 with path halving, each root the smallest index of its tree,
// so that numbering components by their roots in index order is deterministic. Shared by the
// components of an operator (core/components.cpp) and the connected surfaces of a surfel set.
#pragma once

#include <cstddef>
#include <numeric>
#include <utility>
#include <vector>

namespace digilap::detail {

class UnionFind {
public:
  explicit UnionFind(std::size_t n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), std::size_t(0)); }
  std::size_t root(std::size_t i) {
    while (parent_[i] != i) i = parent_[i] = parent_[parent_[i]];
    return i;
  }
  /// Joins the trees of a and b under the smaller of their roots.
  void join(std::size_t a, std::size_t b) {
    a = root(a), b = root(b);
    if (a != b) parent_[std::max(a, b)] = std::min(a, b);
  }

private:
  std::vector<std::size_t> parent_;
};

}  // namespace digilap::detail
