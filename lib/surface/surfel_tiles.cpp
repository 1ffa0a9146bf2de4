#include "surfel_tiles.hpp"

#include "core/gaussian_kernel.hpp"

#include <algorithm>
#include <cstdint>

namespace digilap::surface::detail {

Tiles::Tiles(const Grid& grid) : items_(static_cast<Eigen::Index>(grid.items.size())) {
  for (std::size_t c = 0; c + 1 < grid.start.size(); ++c)
    for (Eigen::Index it = grid.start[c]; it < grid.start[c + 1]; it += kTileRows) first_.push_back(it);
}

int Tiles::rows(Eigen::Index tile) const {
  const auto t = static_cast<std::size_t>(tile);
  const Eigen::Index next = t + 1 < first_.size() ? first_[t + 1] : items_;
  return static_cast<int>(std::min(next, first_[t] + kTileRows) - first_[t]);
}

TileLayers::TileLayers(const Grid& grid, const Tiles& tiles) {
  const Eigen::Index per_layer = grid.cells_per_layer(), layers = grid.layers();
  item.resize(static_cast<std::size_t>(layers + 1));
  tile.resize(static_cast<std::size_t>(layers + 1));
  Eigen::Index t = 0;
  for (Eigen::Index l = 0; l <= layers; ++l) {
    const Eigen::Index first = grid.start[static_cast<std::size_t>(l * per_layer)];
    while (t < tiles.size() && tiles.first(t) < first) ++t;
    item[static_cast<std::size_t>(l)] = first, tile[static_cast<std::size_t>(l)] = t;
  }
}

int TileLayers::segment_ends(Eigen::Index layer, int reach, const int* col, std::size_t count, Eigen::Index* end) const {
  const int segments = static_cast<int>(std::min<Eigen::Index>(reach, layers() - 1 - layer)) + 1;
  for (int d = 0; d < segments; ++d) {
    const auto next = static_cast<int>(item[static_cast<std::size_t>(layer + d + 1)]);
    end[d] = d + 1 == segments ? static_cast<Eigen::Index>(count) : std::lower_bound(col, col + count, next) - col;
  }
  return segments;
}

void WeightRow::resize(std::size_t n) {
  storage_.resize(static_cast<std::size_t>(gaussian_weights_room(static_cast<Eigen::Index>(n))) + 8);
  const auto address = reinterpret_cast<std::uintptr_t>(storage_.data());
  data_ = storage_.data() + ((64 - address % 64) % 64) / sizeof(double);
}

void TileBuffer::reserve(std::size_t n) {
  if (col.size() >= n) return;
  n *= 2;
  col.resize(n), x.resize(n), y.resize(n), z.resize(n), nx.resize(n), ny.resize(n), nz.resize(n), value.resize(n);
  for (int r = 0; r < kTileRows; ++r) chord2[r].resize(n), d2[r].resize(n);
}

namespace {
// The grid items of [begin, end) within `reach2` (squared) of `centre`, appended to `col` from
// `count` on; returns the new count. Their distances first, in a loop that vectorizes; then a
// branch-free compaction of indices alone (copying each candidate's coordinates in the same
// loop made every store wait on the previous comparison).
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) std::size_t near_items(
    const double* __restrict xs, const double* __restrict ys, const double* __restrict zs, std::size_t begin, std::size_t end,
    const double* centre, double reach2, double* __restrict distance2, int* __restrict col, std::size_t count) {
  const double cx = centre[0], cy = centre[1], cz = centre[2];
  const std::size_t n = end - begin;
  for (std::size_t k = 0; k < n; ++k) {
    const double dx = xs[begin + k] - cx, dy = ys[begin + k] - cy, dz = zs[begin + k] - cz;
    distance2[k] = dx * dx + dy * dy + dz * dz;
  }
  for (std::size_t k = 0; k < n; ++k) {
    col[count] = static_cast<int>(begin + k);
    count += distance2[k] <= reach2;
  }
  return count;
}

// The kept candidates' coordinates, normals (when the grid has them) and values, contiguous.
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void gather_candidates(
    const Grid& grid, const double* per_item, std::size_t count, TileBuffer& buffer) {
  const int* __restrict col = buffer.col.data();
  auto gather = [&](const double* __restrict from, std::vector<double>& to) {
    double* __restrict out = to.data();
    for (std::size_t k = 0; k < count; ++k) out[k] = from[col[k]];
  };
  gather(grid.xs.data(), buffer.x), gather(grid.ys.data(), buffer.y), gather(grid.zs.data(), buffer.z);
  if (per_item) gather(per_item, buffer.value);
  if (!grid.nxs.empty()) gather(grid.nxs.data(), buffer.nx), gather(grid.nys.data(), buffer.ny), gather(grid.nzs.data(), buffer.nz);
}
}  // namespace

std::size_t gather_tile_candidates(const Grid& grid, Eigen::Index first, int rows, double cut, const double* per_item,
                                   TileBuffer& buffer, Eigen::Index from) {
  const auto at = [&](int r) {
    const auto it = static_cast<std::size_t>(first + r);
    return Eigen::Vector3d(grid.xs[it], grid.ys[it], grid.zs[it]);
  };
  Eigen::Vector3d lo = at(0), hi = lo;
  for (int r = 1; r < rows; ++r) lo = lo.cwiseMin(at(r)), hi = hi.cwiseMax(at(r));
  // Within the cut of a row => within cut + radius of the centre (1e-9 above: rounding).
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  const double reach = (cut + 0.5 * (hi - lo).norm()) * (1 + 1e-9);
  std::size_t count = 0;
  grid.for_candidates(lo, hi, cut, [&](Eigen::Index begin, Eigen::Index end) {
    begin = std::max(begin, from);
    if (end <= begin) return;
    buffer.reserve(count + static_cast<std::size_t>(end - begin));
    count = near_items(grid.xs.data(), grid.ys.data(), grid.zs.data(), static_cast<std::size_t>(begin), static_cast<std::size_t>(end),
                       centre.data(), reach * reach, buffer.chord2[0].data(), buffer.col.data(), count);
  });
  gather_candidates(grid, per_item, count, buffer);
  return count;
}

}  // namespace digilap::surface::detail
