#include "digilap/surface/matrix_free.hpp"

#include "digilap/core/error.hpp"
#include "core/block_ldlt.hpp"
#include "core/eigen_checks.hpp"
#include "core/gaussian_kernel.hpp"
#include "core/huge_pages.hpp"
#include "core/lanes.hpp"
#include "core/lobpcg.hpp"
#include "core/spectrum_parts.hpp"
#include "core/union_find.hpp"
#include "coarse_spread.hpp"
#include "intrinsic_kernel.hpp"
#include "surfel_grid.hpp"
#include "surfel_tiles.hpp"


#include <algorithm>
#include <limits>
#include <mutex>
#include <numeric>
#include <cstring>
#include <cmath>
#include <sstream>
#include <type_traits>
#include <unordered_map>

namespace digilap::surface {

// The products' grid: cells of half the cut, each holding many surfels, so that few of its
// tiles are partial (a torus at h = 0.025, N = 35,936: the tiles' candidates were 1.29 times a
// row's own neighbours, 1.38 with cells of a quarter of the cut; a product of 30 columns
// 0.168 s against 0.198 s).
constexpr double kCellsPerCut = 2;

// One surface: its grid over its own centres (rows local to the surface) and its kernel. With
// the intrinsic kernel, the grid holds the normals (in its item order, the queries' too), and
// the weights' measures are mu (1 + g), each row scaled by its 1 + g (intrinsic_kernel.hpp).
struct detail::SurfacePart {
  Eigen::Index first = 0, rows = 0;
  detail::Grid grid;
  detail::Kernel kernel;
  Eigen::VectorXd mass_in_grid;    // the weights' measures in that order
  Eigen::VectorXd row_scale;       // 1 + g_i in that order (ones for the chord)
  SurfacePart(Eigen::Index first_, const Eigen::MatrixX3d& positions, const detail::Kernel& k, const Eigen::VectorXd& mass,
       const Eigen::MatrixX3d* normals_)
      : first(first_), rows(positions.rows()), grid(positions, k.cut, normals_, kCellsPerCut, true), kernel(k) {
    Eigen::VectorXd factor = Eigen::VectorXd::Ones(rows);
    if (normals_)
      factor = detail::curvature_factors(grid, positions, *normals_, mass.segment(first, rows), kernel);
    mass_in_grid.resize(rows);
    row_scale.resize(rows);
    for (std::size_t it = 0; it < grid.items.size(); ++it) {
      const Eigen::Index r = grid.items[it];
      mass_in_grid[static_cast<Eigen::Index>(it)] = normals_ ? mass[first + r] * factor[r] : mass[first + r];
      row_scale[static_cast<Eigen::Index>(it)] = factor[r];
    }
  }
  // The products' tiles (surfel_tiles.hpp).
  detail::Tiles tiles{grid};
  // Each row's sum of weights sum_j w_ij mu_j (grid order), from the constructor's pass: the
  // diagonal of the products that take each pair once (apply_part), which see half a row.
  Eigen::VectorXd row_sum;
  // The grid's layers of cells along its slowest axis, the surface's longest extent (more layers
  // share the threads better: a torus lying flat at h = 0.025 has 5 along z, 15 along x).
  detail::TileLayers layers;
  // The products' blocks (z and the images, apply_part), kept from one product to the next:
  // faulting four fresh blocks in was a third of a small surface's spectrum (a torus at
  // h = 0.05: 0.95 s against 0.73 s). One product at a time uses them; a product that runs
  // while another holds them allocates its own.
  mutable std::mutex scratch_mutex;
  mutable Eigen::MatrixXd scratch_z;
  mutable std::vector<Eigen::MatrixXd> scratch_image;
  bool intrinsic() const { return !grid.nxs.empty(); }
  // The weights kept (HeatLaplacianOptions::stored_weights_bytes), empty when not: tile t's
  // candidates after its first row are col[offset[t], offset[t + 1]), as grid positions, its row
  // r's kernel values on them start at weight[kTileRows offset[t] + r count] (upper_tile).
  struct StoredTiles {
    std::vector<std::size_t> offset;
    std::vector<int> col;
    std::vector<double> weight;
    bool kept() const { return !offset.empty(); }
    // Bytes of `candidates` candidates over `tiles` tiles: the estimate before keeping them and
    // the count after are the same formula.
    static double bytes_for(std::size_t candidates, std::size_t tiles) {
      return static_cast<double>(candidates) * (sizeof(int) + detail::kTileRows * sizeof(double)) +
             static_cast<double>(tiles + 1) * sizeof(std::size_t);
    }
    double bytes() const { return kept() ? bytes_for(col.size(), offset.size() - 1) : 0.0; }
  } stored;
};

MatrixFreeSurfaceOperator::~MatrixFreeSurfaceOperator() = default;
MatrixFreeSurfaceOperator::MatrixFreeSurfaceOperator(MatrixFreeSurfaceOperator&&) noexcept = default;
MatrixFreeSurfaceOperator& MatrixFreeSurfaceOperator::operator=(MatrixFreeSurfaceOperator&&) noexcept = default;

namespace {
using digilap::detail::Lanes8;
using digilap::detail::Lanes8u;  // a neighbour's values need not start on 64 bytes

// A product takes each pair of rows (i, j) once, from the tile (surfel_tiles.hpp: up to 8
// consecutive grid items of one cell, a few h apart) of the first of them in the grid's order:
// the kernel's value g_ij goes into row i's sum and into row j's image, each loaded once for the
// tile's 8 rows. Computing every pair from both rows, as the products did before, took twice the
// searches, distances and Gaussians, the larger part of a product at small h (a sphere at
// h = 0.0125: a spectrum 35 s against 25 s; docs/benchmarks.md). Every sum runs in a fixed
// order, whatever the thread that computes it (apply_part).
constexpr Eigen::Index kLanes = 8;
// The grid's reach in layers is ceil(cut / cell) with cells of at least half the cut: 2, or 3
// by rounding.
constexpr int kMaxLayersAhead = 3;
Eigen::Index padded_columns(Eigen::Index b) { return b < kLanes ? b : (b + kLanes - 1) / kLanes * kLanes; }
const bool kWideVectors = __builtin_cpu_supports("avx512f");

// Each pair once: for the R rows i_r of a tile and the candidates k after them (weights g_r[k],
// 0 where a pair is not one), the rows' sums out_r += sum_k g_r[k] z_k and the candidates'
// images y_k += sum_r g_r[k] z_{i_r}, V * 8 columns from z, y and out on (z = mu x, every
// row `stride` values). The candidates fall into `segments` runs, the s-th ending at end[s]
// and written to target[s] (the layer of the tile, the next, the one after). The rows' sums
// and z_{i_r} are held in registers (R V + R V of them: with R = 8 and V = 2, 32, so the
// compiler keeps some z_{i_r} in L1 instead; still the fastest, see symmetric_tile_rows).
template <int R, int V>
__attribute__((always_inline)) inline void symmetric_tile(const double* const* g, const int* col, const Eigen::Index* end, int segments,
                                                         double* const* target, const double* z, Eigen::Index stride,
                                                         const double* const* z_rows, double* const* out) {
  Lanes8 sum[R][V] = {}, u[R][V];
  for (int r = 0; r < R; ++r)
    for (int v = 0; v < V; ++v) u[r][v] = *reinterpret_cast<const Lanes8u*>(z_rows[r] + 8 * v);
  Eigen::Index k = 0;
  for (int segment = 0; segment < segments; ++segment) {
    double* y = target[segment];
    for (; k < end[segment]; ++k) {
      const std::ptrdiff_t at = static_cast<std::ptrdiff_t>(col[k]) * stride;
      const Lanes8u* zk = reinterpret_cast<const Lanes8u*>(z + at);
      Lanes8u* yk = reinterpret_cast<Lanes8u*>(y + at);
      Lanes8 zv[V], yv[V];
      for (int v = 0; v < V; ++v) zv[v] = zk[v], yv[v] = yk[v];
      for (int r = 0; r < R; ++r) {
        const double gk = g[r][k];
        for (int v = 0; v < V; ++v) sum[r][v] += gk * zv[v], yv[v] += gk * u[r][v];
      }
      for (int v = 0; v < V; ++v) yk[v] = yv[v];
    }
  }
  for (int r = 0; r < R; ++r)
    for (int v = 0; v < V; ++v) {
      Lanes8u* o = reinterpret_cast<Lanes8u*>(out[r] + 8 * v);
      *o = *o + sum[r][v];
    }
}

template <int R>
__attribute__((always_inline)) inline void symmetric_rows(const double* const* g, const int* col, const Eigen::Index* end, int segments,
                                                         double* const* target, const double* z, Eigen::Index b,
                                                         const double* const* z_rows, double* const* out, bool wide) {
  double* t[kMaxLayersAhead + 1];
  const double* zr[R];
  double* o[R];
  Eigen::Index c = 0;
  auto pass = [&](auto columns) {  // columns: V * 8 of them, from c
    for (int s = 0; s < segments; ++s) t[s] = target[s] + c;
    for (int r = 0; r < R; ++r) zr[r] = z_rows[r] + c, o[r] = out[r] + c;
    symmetric_tile<R, decltype(columns)::value / 8>(g, col, end, segments, t, z + c, b, zr, o);
    c += decltype(columns)::value;
  };
  // AVX-512: 16 columns a pass (R x 2 registers of sums and as many of the rows' values); else 8.
  if (wide)
    for (; c + 16 <= b;) pass(std::integral_constant<int, 16>{});
  for (; c < b;) pass(std::integral_constant<int, 8>{});
}

// Fewer than 8 columns, unpadded (b values a row: a heat step, one product of the convergence
// sweep), column by column: the rows' sums in 8 partial sums over the candidates 8 at a time,
// added in a fixed order at the end (one sum a row was a chain of dependent additions), the
// candidates' images 8 at a time, then added to theirs one by one.
template <int R>
__attribute__((always_inline)) inline void symmetric_narrow(const double* const* g, const int* col, const Eigen::Index* end, int segments,
                                                           double* const* target, const double* z, Eigen::Index b,
                                                           const double* const* z_rows, double* const* out) {
  for (Eigen::Index c = 0; c < b; ++c) {
    double u[R], tail[R] = {};
    Lanes8 partial[R] = {};
    for (int r = 0; r < R; ++r) u[r] = z_rows[r][c];
    Eigen::Index k = 0;
    for (int segment = 0; segment < segments; ++segment) {
      double* y = target[segment];
      for (; k + 8 <= end[segment]; k += 8) {
        Lanes8 zv, image = {};
        for (int l = 0; l < 8; ++l) zv[l] = z[static_cast<std::ptrdiff_t>(col[k + l]) * b + c];
        for (int r = 0; r < R; ++r) {
          const Lanes8 gv = *reinterpret_cast<const Lanes8u*>(g[r] + k);
          partial[r] += gv * zv, image += gv * u[r];
        }
        for (int l = 0; l < 8; ++l) y[static_cast<std::ptrdiff_t>(col[k + l]) * b + c] += image[l];
      }
      for (; k < end[segment]; ++k) {
        const double zk = z[static_cast<std::ptrdiff_t>(col[k]) * b + c];
        double image = 0;
        for (int r = 0; r < R; ++r) tail[r] += g[r][k] * zk, image += g[r][k] * u[r];
        y[static_cast<std::ptrdiff_t>(col[k]) * b + c] += image;
      }
    }
    for (int r = 0; r < R; ++r) {
      double sum = 0;
      for (int l = 0; l < 8; ++l) sum += partial[r][l];
      out[r][c] += sum + tail[r];
    }
  }
}

// The products' hot loop, for the `rows` rows of a tile: symmetric_rows from 8 columns on (padded
// to a multiple of 8), symmetric_narrow below. Built for AVX-512, AVX2 and the baseline, chosen at
// run time (the same CPU always runs the same build, so results do not depend on the threads).
// A full tile's 8 rows go through each candidate's values together: each load of a neighbour's
// z and image then serves 8 rows, not 4. Where a tile's neighbours' blocks outgrow the caches
// (a sphere at h = 0.0125: 5,000 neighbours a row, 256 bytes each of z and of the image for 30
// columns) the multiply-adds wait on those loads, and 30-column products took 2.5 s with 4-row
// tiles against 1.7-1.9 s (an Intel Ice Lake server, 2 threads; docs/benchmarks.md). The other
// sizes split into 4 rows and the rest, with fewer registers; so do the narrow products, whose
// time is the kernel's values, and so does AVX2, whose 16 registers already hold 4 rows' sums
// and values.
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void symmetric_tile_rows(
    const double* const* g, int rows, const int* col, const Eigen::Index* end, int segments, double* const* target, const double* z,
    Eigen::Index b, const double* const* z_rows, double* const* out) {
  if (b < kLanes) {
    if (rows > 4) {
      symmetric_narrow<4>(g, col, end, segments, target, z, b, z_rows, out);
      g += 4, z_rows += 4, out += 4, rows -= 4;
    }
    switch (rows) {
      case 4: symmetric_narrow<4>(g, col, end, segments, target, z, b, z_rows, out); break;
      case 3: symmetric_narrow<3>(g, col, end, segments, target, z, b, z_rows, out); break;
      case 2: symmetric_narrow<2>(g, col, end, segments, target, z, b, z_rows, out); break;
      default: symmetric_narrow<1>(g, col, end, segments, target, z, b, z_rows, out); break;
    }
    return;
  }
  if (rows == 8 && kWideVectors) {
    symmetric_rows<8>(g, col, end, segments, target, z, b, z_rows, out, kWideVectors);
    return;
  }
  if (rows > 4) {
    symmetric_rows<4>(g, col, end, segments, target, z, b, z_rows, out, kWideVectors);
    g += 4, z_rows += 4, out += 4, rows -= 4;
  }
  switch (rows) {
    case 4: symmetric_rows<4>(g, col, end, segments, target, z, b, z_rows, out, kWideVectors); break;
    case 3: symmetric_rows<3>(g, col, end, segments, target, z, b, z_rows, out, kWideVectors); break;
    case 2: symmetric_rows<2>(g, col, end, segments, target, z, b, z_rows, out, kWideVectors); break;
    default: symmetric_rows<1>(g, col, end, segments, target, z, b, z_rows, out, kWideVectors); break;
  }
}

// The upper triangle of a tile: its candidates from its first row on (as grid positions, in
// the grid's order), each row's kernel values g[r][k] on them, 0 outside the row's cut and at or
// before the row itself; returns their count. g points into `buffer`.
template <class Part>
std::size_t upper_tile(const Part& part, Eigen::Index first, int rows, detail::TileBuffer& buffer, double** g) {
  const detail::Grid& grid = part.grid;
  const detail::Kernel& kernel = part.kernel;
  const std::size_t count = detail::gather_tile_candidates(grid, first, rows, kernel.cut, nullptr, buffer, first);
  const double cut2 = kernel.cut * kernel.cut;
  const int* col = buffer.col.data();
  for (int r = 0; r < rows; ++r) {
    const auto at = static_cast<std::size_t>(first + r);
    const int self = static_cast<int>(at);
    const double q[3] = {grid.xs[at], grid.ys[at], grid.zs[at]};
    g[r] = buffer.d2[r].data();
    // Squared distances, +infinity off the upper triangle or beyond the cut (a weight of 0).
    if (part.intrinsic()) {
      const double nq[3] = {grid.nxs[at], grid.nys[at], grid.nzs[at]};
      detail::upper_intrinsic_distances(buffer.x.data(), buffer.y.data(), buffer.z.data(), buffer.nx.data(), buffer.ny.data(),
                                        buffer.nz.data(), col, count, q, nq, cut2, self, g[r]);
    } else {
      for (std::size_t k = 0; k < count; ++k) {
        const double dx = buffer.x[k] - q[0], dy = buffer.y[k] - q[1], dz = buffer.z[k] - q[2];
        const double chord2 = dx * dx + dy * dy + dz * dz;
        g[r][k] = chord2 <= cut2 && col[k] > self ? chord2 : std::numeric_limits<double>::infinity();
      }
    }
    gaussian_weights_wide(g[r], static_cast<Eigen::Index>(count), kernel.inv_4t, kernel.scale);
  }
  return count;
}

// f(layer, tile, first, rows, col, g, count) for each tile of a part with its upper triangle
// (upper_tile, or the same values kept in Part::stored): the grid's z layers in parallel, the
// tiles of a layer in order on one thread. A pair's second row is at most grid.reach layers
// after its first, so that a layer's products write only to its own rows and to those of the
// next grid.reach layers (apply_part keeps one image a layer distance).
template <class Part, class F>
void for_each_upper_tile(const Part& part, F&& f) {
  const auto& stored = part.stored;
#pragma omp parallel
  {
    detail::TileBuffer buffer;  // this thread's
    double* g[detail::kTileRows];
#pragma omp for schedule(dynamic, 1)
    for (Eigen::Index layer = 0; layer < part.layers.layers(); ++layer)
      for (Eigen::Index tile = part.layers.tile[static_cast<std::size_t>(layer)]; tile < part.layers.tile[static_cast<std::size_t>(layer + 1)];
           ++tile) {
        const Eigen::Index first = part.tiles.first(tile);
        const int rows = part.tiles.rows(tile);
        if (stored.kept()) {
          const auto t = static_cast<std::size_t>(tile);
          const std::size_t begin = stored.offset[t], count = stored.offset[t + 1] - begin;
          const double* kept[detail::kTileRows];
          for (int r = 0; r < rows; ++r) kept[r] = stored.weight.data() + detail::kTileRows * begin + static_cast<std::size_t>(r) * count;
          f(layer, tile, first, rows, stored.col.data() + begin, static_cast<const double* const*>(kept), count);
        } else {
          const std::size_t count = upper_tile(part, first, rows, buffer, g);
          f(layer, tile, first, rows, buffer.col.data(), static_cast<const double* const*>(g), count);
        }
      }
  }
}

// Sums of each row of a part over its pairs, received = sum_j g_ij z_j for z in the grid's order
// (a column per row, from 8 values on padded to a multiple of 8), returned in image[0]; `counts`,
// if given, gets each tile's candidates. The images, in the grid's order: image[d] holds what rows receive from the
// tiles d layers before theirs (for_each_upper_tile), written by that layer's thread in the
// order of its tiles, and they are added in the order of d: the same bits whatever the threads.
template <class Part>
const Eigen::MatrixXd& received(const Part& part, const Eigen::MatrixXd& z, std::vector<Eigen::MatrixXd>& image,
                                std::vector<std::size_t>* counts) {
  const Eigen::Index n = part.rows, padded = z.rows();
  const int ahead = part.grid.reach;
  if (ahead > kMaxLayersAhead) throw Error("MatrixFreeSurfaceOperator: a grid reach of " + std::to_string(ahead) + " layers (internal error)");
  image.resize(static_cast<std::size_t>(ahead + 1));
  for (Eigen::MatrixXd& m : image) digilap::detail::resize_on_huge_pages(m, padded, n);
  // Zeroed, and summed at the end, over the threads: element by element, in the same order
  // whatever the thread (serial, these passes were a third of a 30-column product's time on two
  // threads at N = 30,000).
#pragma omp parallel for schedule(static)
  for (Eigen::Index it = 0; it < n; ++it)
    for (Eigen::MatrixXd& m : image) m.col(it).setZero();
  if (counts) counts->assign(static_cast<std::size_t>(part.tiles.size()), 0);
  for_each_upper_tile(part, [&](Eigen::Index layer, Eigen::Index tile, Eigen::Index first, int rows, const int* col, const double* const* g,
                                std::size_t count) {
    if (counts) (*counts)[static_cast<std::size_t>(tile)] = count;
    double* target[kMaxLayersAhead + 1];
    Eigen::Index end[kMaxLayersAhead + 1];
    // The candidates are in the grid's order: those of each layer ahead follow each other.
    const int segments = part.layers.segment_ends(layer, ahead, col, count, end);
    for (int d = 0; d < segments; ++d) target[d] = image[static_cast<std::size_t>(d)].data();
    const double* z_rows[detail::kTileRows];
    double* out[detail::kTileRows];
    for (int r = 0; r < rows; ++r) z_rows[r] = z.col(first + r).data(), out[r] = image[0].col(first + r).data();
    symmetric_tile_rows(g, rows, col, end, segments, target, z.data(), padded, z_rows, out);
  });
#pragma omp parallel for schedule(static)
  for (Eigen::Index it = 0; it < n; ++it)
    for (int d = 1; d <= ahead; ++d) image[0].col(it) += image[static_cast<std::size_t>(d)].col(it);
  return image[0];
}

// Keeps a part's upper triangles (Part::stored) when their `counts` of candidates (received's)
// take at most `budget` bytes; returns the bytes kept.
template <class Part>
double store_weights(Part& part, const std::vector<std::size_t>& counts, double budget) {
  const std::size_t tiles = counts.size();
  std::vector<std::size_t> offset(tiles + 1, 0);
  for (std::size_t t = 0; t < tiles; ++t) offset[t + 1] = offset[t] + counts[t];
  if (tiles == 0 || Part::StoredTiles::bytes_for(offset.back(), tiles) > budget) return 0;
  auto& stored = part.stored;
  stored.col.resize(offset.back());
  stored.weight.resize(detail::kTileRows * offset.back());
#pragma omp parallel
  {
    detail::TileBuffer buffer;
    double* g[detail::kTileRows];
#pragma omp for schedule(dynamic, 16)
    for (Eigen::Index tile = 0; tile < part.tiles.size(); ++tile) {
      const auto t = static_cast<std::size_t>(tile);
      const int rows = part.tiles.rows(tile);
      const std::size_t n = upper_tile(part, part.tiles.first(tile), rows, buffer, g);
      std::copy(buffer.col.begin(), buffer.col.begin() + static_cast<std::ptrdiff_t>(n), stored.col.begin() + static_cast<std::ptrdiff_t>(offset[t]));
      for (int r = 0; r < rows; ++r)
        std::copy(g[r], g[r] + n,
                  stored.weight.begin() + static_cast<std::ptrdiff_t>(detail::kTileRows * offset[t] + static_cast<std::size_t>(r) * n));
    }
  }
  stored.offset = std::move(offset);
  return stored.bytes();
}

// What a part's products need besides its grid: its layers, and each row's sum of weights,
// sum_j g_ij mu_j, from the products' own loop on mu (the diagonal then cancels the products'
// constant part to rounding), which also counts each tile's candidates (for store_weights).
void prepare_products(detail::SurfacePart& part, std::vector<std::size_t>* candidates) {
  part.layers = detail::TileLayers(part.grid, part.tiles);
  std::vector<Eigen::MatrixXd> image;
  const Eigen::MatrixXd& sums = received(part, part.mass_in_grid.transpose(), image, candidates);
  part.row_sum = sums.row(0).transpose();
}

// A product on one part: z = mu x in the grid's order (fill(it, z_it) writes the b values of
// grid item it), its sums over the pairs (received), and write(it, sums_it) for each item.
// z holds each row's b values contiguously (the inner loop runs over them), from 8 on padded
// with zeros to a multiple of 8, rows in the grid's order (a row's neighbours are then a few
// runs of memory).
template <class Fill, class Write>
void product_in_grid_order(const detail::SurfacePart& part, Eigen::Index b, const Fill& fill, const Write& write) {
  const Eigen::Index padded = padded_columns(b), n = part.rows;
  // The blocks are the part's own (SurfacePart::scratch_z), or, when they are in use, fresh ones on huge
  // pages, asked for before they are written (faulting 4 KiB pages in was about a tenth of a
  // torus's spectrum at h = 0.025, 67,000 faults; docs/benchmarks.md).
  std::unique_lock<std::mutex> scratch(part.scratch_mutex, std::try_to_lock);
  Eigen::MatrixXd own_z;
  std::vector<Eigen::MatrixXd> own_image;
  Eigen::MatrixXd& z = scratch.owns_lock() ? part.scratch_z : own_z;
  std::vector<Eigen::MatrixXd>& image = scratch.owns_lock() ? part.scratch_image : own_image;
  digilap::detail::resize_on_huge_pages(z, padded, n);
#pragma omp parallel for schedule(static)
  for (Eigen::Index it = 0; it < n; ++it) {
    fill(it, z.col(it).head(b));
    z.col(it).tail(padded - b).setZero();
  }
  const Eigen::MatrixXd& sums = received(part, z, image, nullptr);
#pragma omp parallel for schedule(static)
  for (Eigen::Index it = 0; it < n; ++it) write(it, sums.col(it));
}

// Y = A X (stiffness) or L X on one part, X and Y holding its rows.
void part_product(const detail::SurfacePart& part, const Eigen::MatrixXd& x, Eigen::MatrixXd& y, bool stiffness) {
  if (x.rows() != part.rows)
    throw Error("MatrixFreeSurfaceOperator: a block of " + std::to_string(x.rows()) + " rows for a surface of " +
                std::to_string(part.rows));
  const Eigen::Index b = x.cols();
  digilap::detail::resize_on_huge_pages(y, part.rows, b);
  // y_i = s_i (sum_j g_ij mu_j x_j - sum_i x_i), s_i = mu_i (A) or 1 + g_i (L): the assembled row.
  product_in_grid_order(
      part, b,
      [&](Eigen::Index it, auto z) { z = part.mass_in_grid[it] * x.row(part.grid.items[static_cast<std::size_t>(it)]).transpose(); },
      [&](Eigen::Index it, const auto& sums) {
        const Eigen::Index row = part.grid.items[static_cast<std::size_t>(it)];
        const double scale = stiffness ? part.mass_in_grid[it] : part.row_scale[it], sum = part.row_sum[it];
        for (Eigen::Index c = 0; c < b; ++c) y(row, c) = scale * (sums[c] - sum * x(row, c));
      });
}

// Y = S (-A) S X on the rows of a part that `local` numbers (local[row]: the row's row in X and
// Y, or -1 for a row left out, which counts as zero), S = diag(s): the symmetric form a spectrum
// iterates on, written straight into y (a view of the solver's block). The same arithmetic as
// scaling, scattering onto the part's rows, part_product and gathering back, without those
// three blocks of the part's size.
void symmetric_part_product(const detail::SurfacePart& part, const std::vector<Eigen::Index>& local, const Eigen::VectorXd& s,
                            const digilap::detail::BlockIn& x, digilap::detail::BlockOut y) {
  const Eigen::Index b = x.cols();
  auto row_of = [&](Eigen::Index it) { return local[static_cast<std::size_t>(part.grid.items[static_cast<std::size_t>(it)])]; };
  product_in_grid_order(
      part, b,
      [&](Eigen::Index it, auto z) {
        const Eigen::Index k = row_of(it);
        if (k < 0) z.setZero();
        else
          for (Eigen::Index c = 0; c < b; ++c) z[c] = part.mass_in_grid[it] * (s[k] * x(k, c));
      },
      [&](Eigen::Index it, const auto& sums) {
        const Eigen::Index k = row_of(it);
        if (k < 0) return;
        const double scale = part.mass_in_grid[it], sum = part.row_sum[it];
        for (Eigen::Index c = 0; c < b; ++c) y(k, c) = s[k] * -(scale * (sums[c] - sum * (s[k] * x(k, c))));
      });
}

}  // namespace

MatrixFreeSurfaceOperator::MatrixFreeSurfaceOperator(const SurfelSet& surfels, const SurfelMeasures& measures,
                                                     const HeatLaplacianOptions& options) {
  if (options.richardson) throw Error("MatrixFreeSurfaceOperator: Richardson extrapolation is not available in 3D");
  const auto n = static_cast<Eigen::Index>(surfels.size());
  if (measures.mu.size() != n)
    throw Error("MatrixFreeSurfaceOperator: " + std::to_string(measures.mu.size()) + " measures for " + std::to_string(n) + " surfels");
  require_positive("MatrixFreeSurfaceOperator: k", options.k);
  const detail::PartLayout layout = part_layout(surfels, measures, options);
  row_offset_ = layout.row_offset;
  part_t_ = layout.part_t;
  t_ = layout.t, cut_ = layout.cut, length_scale_ = layout.length_scale, h_ = surfels.h;
  mass_ = measures.mu;
  const bool intrinsic = options.surface_kernel == SurfaceKernel::Intrinsic;
  if (intrinsic) detail::check_intrinsic_normals("MatrixFreeSurfaceOperator", measures, n);
  const Eigen::MatrixX3d positions = surfels.centres();
  // The weights kept take at most stored_weights_bytes, and never more than a quarter of the memory limit.
  double weight_budget = std::min(options.stored_weights_bytes, 0.25 * options.memory_limit_bytes);
  a_diagonal_ = Eigen::VectorXd::Zero(n);
  l_row_sums_ = Eigen::VectorXd::Zero(n);
  for (std::size_t p = 0; p + 1 < row_offset_.size(); ++p) {
    const Eigen::Index first = row_offset_[p], rows = row_offset_[p + 1] - first;
    const Eigen::MatrixX3d normals = intrinsic ? Eigen::MatrixX3d(measures.normals.middleRows(first, rows)) : Eigen::MatrixX3d();
    part_.push_back(std::make_unique<detail::SurfacePart>(first, positions.middleRows(first, rows), layout.kernel[p], mass_, intrinsic ? &normals : nullptr));
    detail::SurfacePart& part = *part_.back();
    std::vector<std::size_t> candidates;
    prepare_products(part, &candidates);
    for (Eigen::Index it = 0; it < rows; ++it) {
      const Eigen::Index i = first + part.grid.items[static_cast<std::size_t>(it)];
      l_row_sums_[i] = part.row_scale[it] * part.row_sum[it];
      a_diagonal_[i] = -part.mass_in_grid[it] * part.row_sum[it];
    }
    weight_budget -= store_weights(part, candidates, weight_budget);
  }
  positions_ = positions;
}

double MatrixFreeSurfaceOperator::part_cut(std::size_t p) const {
  if (p >= part_.size()) throw Error("MatrixFreeSurfaceOperator: surface " + std::to_string(p) + " does not exist");
  return part_[p]->kernel.cut;
}

double MatrixFreeSurfaceOperator::bytes() const {
  // Positions (24), masses, diagonals (24), and per grid item its index and coordinates (32);
  // with the intrinsic kernel, the grid's normals (24) and the row scales (8).
  // Plus the weights kept (HeatLaplacianOptions::stored_weights_bytes).
  const bool intrinsic = !part_.empty() && part_.front()->intrinsic();
  double stored = 0;
  for (const auto& part : part_) stored += part->stored.bytes();
  return (intrinsic ? 112.0 : 80.0) * static_cast<double>(rows()) + stored;
}

void MatrixFreeSurfaceOperator::apply_part(std::size_t p, const Eigen::MatrixXd& x, Eigen::MatrixXd& y, bool stiffness) const {
  part_product(part(p), x, y, stiffness);
}

const detail::SurfacePart& MatrixFreeSurfaceOperator::part(std::size_t p) const {
  if (p >= part_.size()) throw Error("MatrixFreeSurfaceOperator: surface " + std::to_string(p) + " does not exist");
  return *part_[p];
}

namespace {
void apply_whole(const MatrixFreeSurfaceOperator& op, const Eigen::MatrixXd& x, Eigen::MatrixXd& y, bool stiffness) {
  if (x.rows() != op.rows())
    throw Error("MatrixFreeSurfaceOperator: a block of " + std::to_string(x.rows()) + " rows for " + std::to_string(op.rows()));
  y.resize(x.rows(), x.cols());
  Eigen::MatrixXd part_y;
  for (std::size_t p = 0; p < op.parts(); ++p) {
    const Eigen::Index first = op.row_offset()[p], rows = op.row_offset()[p + 1] - first;
    op.apply_part(p, x.middleRows(first, rows), part_y, stiffness);
    y.middleRows(first, rows) = part_y;
  }
}
}  // namespace

void MatrixFreeSurfaceOperator::apply_stiffness(const Eigen::MatrixXd& x, Eigen::MatrixXd& y) const { apply_whole(*this, x, y, true); }
void MatrixFreeSurfaceOperator::apply_laplacian(const Eigen::MatrixXd& x, Eigen::MatrixXd& y) const { apply_whole(*this, x, y, false); }

Eigen::MatrixXd bias_corrected_laplacian(const MatrixFreeSurfaceOperator& op, const Eigen::MatrixXd& g, Eigen::MatrixXd* plain) {
  if (g.rows() != op.rows())
    throw Error("bias_corrected_laplacian: " + std::to_string(g.rows()) + " rows for an operator of " + std::to_string(op.rows()));
  return digilap::bias_corrected_laplacian([&](const Eigen::MatrixXd& x, Eigen::MatrixXd& y) { op.apply_laplacian(x, y); },
                                           heat_time_of_rows(op.row_offset(), op.part_t()), g, plain);
}

namespace {
// The preconditioner of one surface's LOBPCG, on its support: x -> s M^(1/2) (K + sigma M)^(-1)
// M^(1/2) x + t x in the symmetric form of the problem (C = M^(-1/2) (-A) M^(-1/2)). K is a graph
// Laplacian scaled as a stiffness; sigma, a hundredth of Weyl's first eigenvalue 4 pi / area
// (times s), makes K + sigma M definite. Which graph depends on the kernel's width in grid steps:
// - wide (sqrt(t) >= 1.5 h: smooth surfaces at small h): unit weights between the surfels whose
//   centres are within 1.01 h (the edge-adjacent ones, at h or h / sqrt(2)), s = 1 (a flat grid's
//   5-point stencil: K / M ~ -Laplacian). 16-20 iterations where the weighted graph below takes
//   20-25 (a torus at h = 0.025).
// - narrow (real segmentations at the length-scale floor, t ~ 0.6 h^2): there the unit graph
//   misleads LOBPCG (a label of Harvard-Oxford at 1 mm: no column converged in 150 iterations),
//   so K is the operator's own stiffness truncated at 1.5 h (its heat-kernel weights m_i m_j
//   exp(-d^2 / 4t) / (4 pi t^2)), and s = 1 - (1 + U) exp(-U), U = (1.5 h)^2 / 4t, the share of
//   the kernel's mass that truncation keeps (the full stiffness is larger than K by about 1 / s).
//   The same label: 38 iterations.
// Either graph must be connected where the operator is. Surfels of zero area, which are off the
// support, can cut it into pieces that the kernel still joins: bands and islands a few h apart.
// A piece the graph leaves apart is a null vector of K, which (K + sigma M)^(-1) amplifies by
// 1 / sigma. Every preconditioned residual is then those few piecewise constants, and LOBPCG
// stalls. Harvard-Oxford 1 mm label 17 shows it: W fell from 75 columns to 4-15 independent
// ones, and after 150 iterations the residual was still 2.5e4 times the tolerance. So the cut
// grows by 1.25 until the graph is connected, at most to the operator's own cut, where it is.
class GraphPreconditioner {
public:
  GraphPreconditioner(const Eigen::MatrixX3d& positions, const Eigen::VectorXd& mass, double h, double t, double operator_cut)
      : t_(t) {
    const Eigen::Index n = positions.rows();
    const bool narrow = std::sqrt(t) < 1.5 * h;
    std::vector<Eigen::Triplet<double>> entries;
    for (double cut = narrow ? 1.5 * h : 1.01 * h;; cut = std::min(1.25 * cut, operator_cut)) {
      const double u = cut * cut / (4 * t);
      scale_ = narrow ? 1 - (1 + u) * std::exp(-u) : 1.0;
      const double sigma = scale_ * 1e-2 * 4 * kPi / mass.sum();
      if (graph_entries(positions, mass, cut, t, narrow, sigma, entries) == 1 || cut >= operator_cut) break;
    }
    Eigen::SparseMatrix<double> k(n, n);
    k.setFromTriplets(entries.begin(), entries.end());
    if (!solver_.compute(k)) throw Error("smallest_eigenpairs (matrix-free surfaces): the preconditioner's factorization failed");
    root_mass_ = mass.cwiseSqrt();
  }
  // The solves 8 columns at a time over the threads (core/block_ldlt.hpp), in y.
  void apply(const digilap::detail::BlockIn& x, digilap::detail::BlockOut y) const {
#pragma omp parallel for schedule(static)
    for (Eigen::Index c = 0; c < x.cols(); ++c) y.col(c) = root_mass_.cwiseProduct(x.col(c));
    solver_.solve_in_place(y);
#pragma omp parallel for schedule(static)
    for (Eigen::Index c = 0; c < x.cols(); ++c) y.col(c) = scale_ * root_mass_.cwiseProduct(y.col(c)) + t_ * x.col(c);
  }

private:
  // K + sigma M's lower triangle within `cut` into `entries`; returns the graph's number of
  // connected components.
  static std::size_t graph_entries(const Eigen::MatrixX3d& positions, const Eigen::VectorXd& mass, double cut, double t,
                                   bool narrow, double sigma, std::vector<Eigen::Triplet<double>>& entries) {
    const Eigen::Index n = positions.rows();
    const detail::Grid grid(positions, cut);
    entries.clear();
    entries.reserve(static_cast<std::size_t>((narrow ? 13 : 7) * n));
    digilap::detail::UnionFind pieces(static_cast<std::size_t>(n));
    detail::RowBuffer found;
    for (Eigen::Index i = 0; i < n; ++i) {
      grid.gather_within(positions.row(i).transpose(), cut, found);
      double degree = 0;
      for (std::size_t k = 0; k < found.size; ++k) {
        const int j = found.col[k];
        if (j == i) continue;
        const double w = narrow ? mass[i] * mass[j] * std::exp(-found.d2[k] / (4 * t)) / (4 * kPi * t * t) : 1.0;
        if (j > i) {  // lower triangle
          entries.emplace_back(static_cast<int>(j), static_cast<int>(i), -w);
          pieces.join(static_cast<std::size_t>(i), static_cast<std::size_t>(j));
        }
        degree += w;
      }
      entries.emplace_back(static_cast<int>(i), static_cast<int>(i), degree + sigma * mass[i]);
    }
    std::size_t count = 0;
    for (std::size_t i = 0; i < static_cast<std::size_t>(n); ++i) count += pieces.root(i) == i;
    return count;
  }

  digilap::detail::BlockLdlt solver_;
  Eigen::VectorXd root_mass_;
  double t_;
  double scale_;  // s above
};

// LOBPCG's start on one surface's support from a coarse problem: the same kernel on aggregates
// of the support (its surfels grouped by cells of kCoarseCell h and, with the intrinsic kernel
// whose grid holds the normals, by their normal's dominant direction, so that the two sides of a
// thin wall stay apart), each at its surfels' centroid with
// their summed area and mean normal. It is a quadrature of the same heat operator on about a
// quarter of the points with a twentieth of the pairs, and its eigenvalues are the surfels' own
// within 0.1% (a torus at h = 0.025). Its `block` smallest eigenvectors, the guards' too, spread
// back to the surfels (smoothly, coarse_spread.hpp: one iteration fewer than each surfel taking
// its aggregate's value, on a torus at h = 0.025 and 0.0125), are the start (only the `count` wanted
// ones converge to kCoarseTolerance, the others need not, as in the surfels' problem: 7 coarse
// iterations instead of 9 on a sphere at h = 0.0125, the same fine ones): LOBPCG's iterations
// are set by how far the start is from the answer (docs/benchmarks.md: 16-17 iterations from a
// random start, 11-12 from this one, on a torus and a sphere at h = 0.025). The guards matter:
// with random ones the last wanted column, one of a pair that the count splits, took 3
// iterations more alone. The coarse problem needs a kernel a few aggregates wide and a surface
// large enough to pay for it (smooth surfaces at small h; not real labels at their length-scale
// floor, where sqrt(t) < h). Returns an empty block when it does not apply or did not converge
// (then the random start).
constexpr double kCoarseCell = 2;   // aggregates: cells of 2 h, about 4.4 surfels each
constexpr double kCoarseWidth = 1;  // sqrt(t) at least one cell
constexpr Eigen::Index kCoarseMinRows = 5000;
// The coarse eigenvectors need only be as close to the surfels' as the two problems are
// (1e-8 instead: the same fine iterations, twice the coarse ones).
constexpr double kCoarseTolerance = 1e-4;
constexpr int kCoarseIterations = 100;

// The start for `count` eigenpairs: `block` columns, or as many as make the block end at a gap
// of the coarse spectrum (block_at_a_gap, core/lobpcg.hpp: more, at most max_block, where the
// block would end inside the last wanted eigenvalue's cluster; fewer where it ends inside the
// cluster of the first eigenvalue past it).
Eigen::MatrixXd coarse_start(const MatrixFreeSurfaceOperator& op, std::size_t p, const std::vector<Eigen::Index>& support,
                             const Eigen::VectorXd& mass, int count, Eigen::Index block, Eigen::Index max_block) {
  const detail::SurfacePart& fine = op.part(p);
  const auto n = static_cast<Eigen::Index>(support.size());
  const double cell = kCoarseCell * op.h(), t = fine.kernel.t;
  if (n < kCoarseMinRows || std::sqrt(t) < kCoarseWidth * cell) return {};
  const Eigen::Index first = op.row_offset()[p];
  // Each row's normal, from the grid (which holds them in its own order) when the kernel has them.
  Eigen::MatrixX3d normal = Eigen::MatrixX3d::Zero(fine.rows, 3);
  for (std::size_t it = 0; fine.intrinsic() && it < fine.grid.items.size(); ++it)
    normal.row(fine.grid.items[it]) << fine.grid.nxs[it], fine.grid.nys[it], fine.grid.nzs[it];
  // Aggregates, numbered in the order of their first surfel (the same on any number of threads).
  Eigen::Vector3d lo = op.positions().row(first + support[0]).transpose();
  Eigen::Vector3d hi = lo;
  for (const Eigen::Index r : support) {
    lo = lo.cwiseMin(op.positions().row(first + r).transpose());
    hi = hi.cwiseMax(op.positions().row(first + r).transpose());
  }
  if (((hi - lo) / cell).maxCoeff() >= double(1 << 20)) return {};  // the keys below hold 20 bits a coordinate
  std::unordered_map<std::uint64_t, int> number;
  std::vector<int> aggregate(static_cast<std::size_t>(n));
  for (Eigen::Index k = 0; k < n; ++k) {
    const Eigen::Index r = support[static_cast<std::size_t>(k)];
    const Eigen::Vector3d at = (op.positions().row(first + r).transpose() - lo) / cell;  // >= 0, < 2^20
    Eigen::Index axis = 0;
    normal.row(r).cwiseAbs().maxCoeff(&axis);
    const std::uint64_t key = (static_cast<std::uint64_t>(at.x()) << 43) | (static_cast<std::uint64_t>(at.y()) << 23) |
                              (static_cast<std::uint64_t>(at.z()) << 3) | static_cast<std::uint64_t>(2 * axis + (normal(r, axis) > 0));
    aggregate[static_cast<std::size_t>(k)] = number.emplace(key, static_cast<int>(number.size())).first->second;
  }
  const auto m = static_cast<Eigen::Index>(number.size());
  if (m <= digilap::detail::kDenseRows || 2 * block + 1 > m) return {};
  Eigen::MatrixX3d positions = Eigen::MatrixX3d::Zero(m, 3), normals = Eigen::MatrixX3d::Zero(m, 3);
  Eigen::VectorXd area = Eigen::VectorXd::Zero(m);
  for (Eigen::Index k = 0; k < n; ++k) {
    const Eigen::Index a = aggregate[static_cast<std::size_t>(k)], r = support[static_cast<std::size_t>(k)];
    positions.row(a) += mass[k] * op.positions().row(first + r);
    normals.row(a) += mass[k] * normal.row(r);
    area[a] += mass[k];
  }
  for (Eigen::Index a = 0; a < m; ++a) {
    positions.row(a) /= area[a];
    if (fine.intrinsic()) normals.row(a).normalize();  // one dominant direction: the sum never cancels
  }
  detail::SurfacePart coarse(0, positions, fine.kernel, area, fine.intrinsic() ? &normals : nullptr);
  prepare_products(coarse, nullptr);
  // C = M^(-1/2) (-A) M^(-1/2) on the aggregates, its bound c and preconditioner as on the surfels.
  const Eigen::VectorXd s = area.cwiseSqrt().cwiseInverse();
  double c = 0;
  for (std::size_t it = 0; it < coarse.grid.items.size(); ++it) {
    const auto at = static_cast<Eigen::Index>(it);
    c = std::max(c, 2 * coarse.mass_in_grid[at] * coarse.row_sum[at] / area[coarse.grid.items[it]]);
  }
  std::vector<Eigen::Index> every_row(static_cast<std::size_t>(m));
  std::iota(every_row.begin(), every_row.end(), Eigen::Index{0});
  auto apply_c = [&](const digilap::detail::BlockIn& x, digilap::detail::BlockOut y) { symmetric_part_product(coarse, every_row, s, x, y); };
  const GraphPreconditioner preconditioner(positions, area, cell, t, fine.kernel.cut);
  const digilap::detail::LobpcgResult result = digilap::detail::lobpcg(
      apply_c, [&](const digilap::detail::BlockIn& x, digilap::detail::BlockOut y) { preconditioner.apply(x, y); },
      digilap::detail::lobpcg_start(m, digilap::detail::lobpcg_block(m, static_cast<int>(block))), count, kCoarseTolerance * c,
      kCoarseIterations, nullptr, true);
  if (!result.converged) return {};
  const Eigen::VectorXd& values = result.values;  // the `count` wanted, then the rest of the coarse block
  // The coarse eigenvalues (the guards' too) show the clusters: the block ends at a gap.
  const Eigen::Index columns = digilap::detail::block_at_a_gap(values, count, block, max_block);
  // The aggregates' eigenvectors u = S y, spread smoothly onto the surfels, in the symmetric
  // form M^(1/2) u of the surfels' problem.
  Eigen::MatrixX3d at(n, 3), at_normal(n, 3);
  for (Eigen::Index k = 0; k < n; ++k) {
    const Eigen::Index r = support[static_cast<std::size_t>(k)];
    at.row(k) = op.positions().row(first + r), at_normal.row(k) = normal.row(r);
  }
  Eigen::MatrixXd start = detail::spread_smoothly(s.asDiagonal() * result.vectors.leftCols(columns), positions, normals, at, at_normal,
                                                  aggregate, cell, fine.intrinsic());
  for (Eigen::Index k = 0; k < n; ++k) start.row(k) *= std::sqrt(mass[k]);
  return start;
}

// One surface's spectrum on the rows of positive area (`support`, local to the surface).
Spectrum part_spectrum(const MatrixFreeSurfaceOperator& op, std::size_t p, const std::vector<Eigen::Index>& support, int count,
                       const SpectrumOptions& o) {
  const Eigen::Index first = op.row_offset()[p], rows = op.row_offset()[p + 1] - first, n = static_cast<Eigen::Index>(support.size());
  Eigen::VectorXd mass(n), s(n);
  for (Eigen::Index r = 0; r < n; ++r) mass[r] = op.mass()[first + support[r]], s[r] = 1 / std::sqrt(mass[r]);
  // C = S (-A) S on the support (S = M^(-1/2)): the surface's other rows count as zero (A's
  // columns vanish there anyway).
  std::vector<Eigen::Index> local(static_cast<std::size_t>(rows), -1);
  for (Eigen::Index r = 0; r < n; ++r) local[static_cast<std::size_t>(support[static_cast<std::size_t>(r)])] = r;
  const detail::SurfacePart& part = op.part(p);
  if (n <= digilap::detail::kDenseRows || 2 * count + 1 > n) {
    constexpr Eigen::Index kDenseLastResort = 3000;
    if (n > kDenseLastResort)
      throw Error("smallest_eigenpairs: " + std::to_string(count) + " eigenpairs of a surface of " + std::to_string(n) +
                  " surfels is more than half of them; ask for fewer");
    Eigen::MatrixXd minus_a_dense(n, n);
    symmetric_part_product(part, local, Eigen::VectorXd::Ones(n), Eigen::MatrixXd::Identity(n, n), minus_a_dense);
    return digilap::detail::dense_spectrum(-minus_a_dense, mass, count);
  }
  const Eigen::Index block = digilap::detail::lobpcg_block(n, count);
  // LOBPCG's blocks and the products' own (z and up to kMaxLayersAhead + 1 images, the part's rows by the block).
  auto bytes_for = [&](Eigen::Index b) {
    const double product_bytes = (kMaxLayersAhead + 2.0) * static_cast<double>(rows) * static_cast<double>(padded_columns(b)) * sizeof(double);
    return digilap::detail::lobpcg_bytes(n, b) + op.bytes() + product_bytes;
  };
  if (bytes_for(block) > o.memory_limit_bytes) {
    std::ostringstream msg;
    msg << "smallest_eigenpairs (matrix-free surfaces): LOBPCG's blocks would take about "
        << digilap::detail::lobpcg_bytes(n, block) / 1e9 << " GB, above the memory limit of " << o.memory_limit_bytes / 1e9
        << " GB; ask for fewer eigenpairs or raise memory_limit_bytes";
    throw Error(msg.str());
  }
  Eigen::MatrixX3d support_positions(n, 3);
  for (Eigen::Index r = 0; r < n; ++r) support_positions.row(r) = op.positions().row(first + support[r]);
  const GraphPreconditioner preconditioner(support_positions, mass, op.h(), op.part_t()[p], op.part_cut(p));
  double c = 0;  // Gershgorin: the eigenvalues of S (-A) S lie in [0, 2 max |A_ii| / m_i]
  for (Eigen::Index r = 0; r < n; ++r) c = std::max(c, 2 * std::abs(op.stiffness_diagonal()[first + support[r]]) / mass[r]);
  auto apply_c = [&](const digilap::detail::BlockIn& x, digilap::detail::BlockOut y) { symmetric_part_product(part, local, s, x, y); };
  // Preconditioned first (16-20 iterations on smooth surfaces, against 30-50 without). On
  // some thin real structures (a tract one or two voxels thick, whose graph joins opposite
  // sides) it stalls: after 150 iterations, the unpreconditioned iteration the assembled
  // operator uses takes over, from the start again.
  const int preconditioned_iterations = std::min(o.max_iterations, 150);
  Eigen::MatrixXd start;
  if (o.coarse_start) {
    Eigen::Index max_block = block;  // the coarse start may take the block past a cluster, within the memory limit
    while (max_block < std::min<Eigen::Index>(2 * block, n / 2) && bytes_for(max_block + 1) <= o.memory_limit_bytes) ++max_block;
    start = coarse_start(op, p, support, mass, count, block, max_block);
  }
  if (start.size() == 0) start = digilap::detail::lobpcg_start(n, block);
  digilap::detail::LobpcgResult result = digilap::detail::lobpcg(
      apply_c, [&](const digilap::detail::BlockIn& x, digilap::detail::BlockOut y) { preconditioner.apply(x, y); }, std::move(start), count,
      o.tolerance * c, preconditioned_iterations, o.progress);
  if (!result.converged) {
    const int spent = result.products;
    result = digilap::detail::lobpcg(
        apply_c, [](const digilap::detail::BlockIn& x, digilap::detail::BlockOut y) { y = x; }, digilap::detail::lobpcg_start(n, block), count,
        o.tolerance * c, o.max_iterations, o.progress);
    result.products += spent;
    result.iterations += preconditioned_iterations;
  }
  if (!result.converged)
    throw Error("smallest_eigenpairs (matrix-free surfaces): LOBPCG did not converge in " + std::to_string(o.max_iterations) +
                " iterations on surface " + std::to_string(p) + "; raise max_iterations or use the assembled operator");
  if (count > 1 && result.values[1] <= 1e-9 * c)  // the pieces were split above: cannot happen
    throw Error("smallest_eigenpairs (matrix-free surfaces): a piece of surface " + std::to_string(p) +
                " has two zero eigenvalues (internal error)");
  Spectrum out;
  out.eigenvalues = result.values;
  out.eigenvectors = s.asDiagonal() * result.vectors;  // M-orthonormal
  out.iterations = result.iterations;
  out.operations = result.products;
  return out;
}
}  // namespace

namespace {
// The pieces of `positions` that links shorter than `reach` connect, each a list of rows in
// ascending order, pieces in order of their first row.
std::vector<std::vector<Eigen::Index>> pieces_within(const Eigen::MatrixX3d& positions, double reach) {
  const Eigen::Index n = positions.rows();
  const detail::Grid grid(positions, reach);
  std::vector<Eigen::Index> piece(static_cast<std::size_t>(n), -1), stack;
  std::vector<std::vector<Eigen::Index>> pieces;
  detail::RowBuffer found;
  for (Eigen::Index seed = 0; seed < n; ++seed) {
    if (piece[seed] >= 0) continue;
    const auto id = static_cast<Eigen::Index>(pieces.size());
    pieces.emplace_back();
    piece[seed] = id;
    stack.assign(1, seed);
    while (!stack.empty()) {
      const Eigen::Index r = stack.back();
      stack.pop_back();
      pieces.back().push_back(r);
      grid.gather_within(positions.row(r).transpose(), reach, found);
      for (std::size_t k = 0; k < found.size; ++k)
        if (piece[found.col[k]] < 0) piece[found.col[k]] = id, stack.push_back(found.col[k]);
    }
  }
  for (auto& rows : pieces) std::sort(rows.begin(), rows.end());
  return pieces;
}

// The pieces of a surface's support (rows local to the surface) that the kernel connects: two
// surfels of positive area interact when within the cut. Zero-area surfels can cut a thin
// surface into pieces, each with its own zero eigenvalue. Pieces in order of their first row.
// Edge-adjacent surfels (centres h or h / sqrt(2) apart) are looked at first: when they already
// join the whole support, so does the wider cut, and the search at the cut (1,000 neighbours a
// row at h = 0.025, 4% of a torus's spectrum) is not needed.
std::vector<std::vector<Eigen::Index>> support_pieces(const MatrixFreeSurfaceOperator& op, std::size_t p,
                                                      const std::vector<Eigen::Index>& support) {
  const auto n = static_cast<Eigen::Index>(support.size());
  const Eigen::Index first = op.row_offset()[p];
  Eigen::MatrixX3d positions(n, 3);
  for (Eigen::Index r = 0; r < n; ++r) positions.row(r) = op.positions().row(first + support[r]);
  const double cut = op.part_cut(p);
  std::vector<std::vector<Eigen::Index>> pieces = pieces_within(positions, std::min(cut, 1.01 * op.h()));
  if (pieces.size() > 1 && cut > 1.01 * op.h()) pieces = pieces_within(positions, cut);
  for (auto& rows : pieces)
    for (Eigen::Index& r : rows) r = support[r];
  return pieces;
}
}  // namespace

Spectrum smallest_eigenpairs(const MatrixFreeSurfaceOperator& op, const SpectrumOptions& o) {
  const Eigen::Index n = op.rows();
  digilap::detail::check_masses(op.mass());
  Eigen::Index with_mass = 0;
  for (Eigen::Index i = 0; i < n; ++i) with_mass += op.mass()[i] > 0;
  digilap::detail::check_solver_options(o.tolerance, o.max_iterations);
  digilap::detail::check_count(with_mass, n - with_mass, o.count);
  std::vector<digilap::detail::SpectrumPart> parts;
  std::vector<Eigen::Index> massless;
  for (std::size_t p = 0; p < op.parts(); ++p) {
    const Eigen::Index first = op.row_offset()[p], last = op.row_offset()[p + 1];
    std::vector<Eigen::Index> support;
    for (Eigen::Index i = first; i < last; ++i) {
      if (op.mass()[i] > 0) {
        support.push_back(i - first);
      } else {
        if (!(op.laplacian_row_sums()[i] > 0))
          throw Error("smallest_eigenpairs: surfel " + std::to_string(i) +
                      " has zero area and no neighbour of positive area within the kernel's cut: its value is undefined");
        massless.push_back(i);
      }
    }
    if (support.empty())
      throw Error("smallest_eigenpairs: surface " + std::to_string(p) + " has no surfel of positive area");
    for (const std::vector<Eigen::Index>& piece : support_pieces(op, p, support)) {
      const int count = static_cast<int>(std::min<Eigen::Index>(o.count, static_cast<Eigen::Index>(piece.size())));
      digilap::detail::SpectrumPart part;
      part.spectrum = part_spectrum(op, p, piece, count, o);
      for (Eigen::Index r : piece) part.rows.push_back(first + r);
      parts.push_back(std::move(part));
    }
  }
  Spectrum s = digilap::detail::merge_parts(parts, n, o.count);
  if (!massless.empty()) {
    // Zero-area surfels: the heat-kernel average of their neighbours, sum_j w_ij mu_j u_j / sum_j w_ij mu_j.
    Eigen::MatrixXd average;
    op.apply_laplacian(s.eigenvectors, average);  // (L u)_i = sum_j w_ij mu_j (u_j - u_i), u_i = 0 here
    for (Eigen::Index i : massless) s.eigenvectors.row(i) = average.row(i) / op.laplacian_row_sums()[i];
    digilap::detail::fix_signs(s.eigenvectors);
    s.massless = static_cast<Eigen::Index>(massless.size());
  }
  if (op.t() > 0)
    digilap::detail::laplace_beltrami_by_contour(s, op.row_offset(), op.part_t(), KernelCut{2, op.cut() / std::sqrt(op.t())});
  return s;
}

}  // namespace digilap::surface
