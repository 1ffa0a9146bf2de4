// Internal: a surfel grid's rows taken a few at a time ("tiles"), with candidates that hold
// every neighbour of the tile's rows within a cut, gathered into contiguous arrays. Shared by
// the matrix-free products (matrix_free.cpp) and the intrinsic kernel's curvature pass
// (intrinsic_kernel.cpp): both evaluate a vectorized expression of each row against the same
// candidates, their positions and normals loaded once for the tile's rows.
#pragma once

#include "surfel_grid.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <vector>

namespace digilap::surface::detail {

// Rows a tile: 8, so that each neighbour's values loaded by a product serve 8 rows (with 4,
// the products of 30 columns on a sphere at h = 0.0125 were a third slower: matrix_free.cpp).
constexpr int kTileRows = 8;

// The tiles of a grid: up to kTileRows consecutive items of one cell each. Within a cell the
// items are in Morton order, a few h apart, so a tile's rows share most neighbours; a tile
// across two cells could join the end of a row of cells to the start of the next, far apart (a
// sphere at h = 0.01 had tiles of 60,000 candidates).
class Tiles {
public:
  explicit Tiles(const Grid& grid);
  Eigen::Index size() const { return static_cast<Eigen::Index>(first_.size()); }
  /// The tile's first grid item and its number of rows (1 to kTileRows).
  Eigen::Index first(Eigen::Index tile) const { return first_[static_cast<std::size_t>(tile)]; }
  int rows(Eigen::Index tile) const;

private:
  std::vector<Eigen::Index> first_;
  Eigen::Index items_ = 0;
};

// A grid's layers of cells along its slowest axis (Grid::layers): layer l's items start at
// item[l], its tiles at tile[l] (tiles never straddle a cell); item[layers()] and tile[layers()]
// are the ends. A pair's second item lies at most grid.reach layers after its first, so a pass
// that takes each pair once, from its first item's tile, and runs the tiles of a layer in order
// on one thread writes only to its layer and the next grid.reach ones: one block of results per
// layer distance, added in that order at the end, gives the same bits whatever the threads (the
// matrix-free products, matrix_free.cpp; the curvature pass, intrinsic_kernel.cpp).
struct TileLayers {
  std::vector<Eigen::Index> item, tile;
  TileLayers() = default;
  TileLayers(const Grid& grid, const Tiles& tiles);
  Eigen::Index layers() const { return static_cast<Eigen::Index>(item.size()) - 1; }
  /// Where the candidates of a tile of `layer` (grid positions in the grid's order, `count` of
  /// them from `col`) pass into each next layer: end[d] for d = 0 .. segments - 1, the last at
  /// count, segments = min(reach, layers - 1 - layer) + 1 (returned).
  int segment_ends(Eigen::Index layer, int reach, const int* col, std::size_t count, Eigen::Index* end) const;
};

// A row's values, 64-byte aligned, with room for gaussian_weights_wide's padding.
class WeightRow {
public:
  void resize(std::size_t n);
  double* data() { return data_; }

private:
  std::vector<double> storage_;
  double* data_ = nullptr;
};

// One thread's buffers for a tile: the candidates (grid positions, coordinates, normals, one
// value of the caller's per item), then per row two arrays of the candidates' length (the
// products: chords and weights; the curvature pass: tangent chords and weights).
struct TileBuffer {
  std::vector<int> col;
  std::vector<double> x, y, z, nx, ny, nz, value;
  std::vector<double> chord2[kTileRows];
  WeightRow d2[kTileRows];
  void reserve(std::size_t n);
};

// The candidates of the tile [first, first + rows): the grid items within `cut` plus the tile's
// radius of its centre (one distance each; every row's neighbours within `cut` among them), in
// the grid's order, into buffer.col as grid positions, with their coordinates, normals (when the
// grid has them) and per_item[col] in buffer.value (unless per_item is null). Only items from
// `from` on: the products' upper-triangle pass takes each pair once, from its first item's tile.
// Returns their count.
std::size_t gather_tile_candidates(const Grid& grid, Eigen::Index first, int rows, double cut, const double* per_item,
                                   TileBuffer& buffer, Eigen::Index from = 0);

}  // namespace digilap::surface::detail
