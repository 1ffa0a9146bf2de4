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
#include "intrinsic_kernel.hpp"
#include "surfel_grid.hpp"
#include "surfel_tiles.hpp"


#include <algorithm>
#include <cstring>
#include <cmath>
#include <sstream>
#include <type_traits>

namespace digilap::surface {

// The products' grid: cells of half the cut, each holding many surfels, so that few of its
// tiles are partial (a torus at h = 0.025, N = 35,936: the tiles' candidates were 1.29 times a
// row's own neighbours, 1.38 with cells of a quarter of the cut; a product of 30 columns
// 0.168 s against 0.198 s).
constexpr double kCellsPerCut = 2;

// One surface: its grid over its own centres (rows local to the surface) and its kernel. With
// the intrinsic kernel, the grid holds the normals (in its item order, the queries' too), and
// the weights' measures are mu (1 + g), each row scaled by its 1 + g (intrinsic_kernel.hpp).
struct MatrixFreeSurfaceOperator::Part {
  Eigen::Index first = 0, rows = 0;
  detail::Grid grid;
  detail::Kernel kernel;
  Eigen::VectorXd mass_in_grid;    // the weights' measures in that order
  Eigen::VectorXd row_scale;       // 1 + g_i in that order (ones for the chord)
  Part(Eigen::Index first_, const Eigen::MatrixX3d& positions, const detail::Kernel& k, const Eigen::VectorXd& mass,
       const Eigen::MatrixX3d* normals_)
      : first(first_), rows(positions.rows()), grid(positions, k.cut, normals_, kCellsPerCut), kernel(k) {
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
  bool intrinsic() const { return !grid.nxs.empty(); }
  // The weights kept (HeatLaplacianOptions::stored_weights_bytes), empty when not: tile t's
  // candidates are col[offset[t], offset[t + 1]), as grid positions, its row r's weights on them
  // start at weight[kTileRows offset[t] + r count], their sums at sum[kTileRows t].
  struct StoredTiles {
    std::vector<std::size_t> offset;
    std::vector<int> col;
    std::vector<double> weight, sum;
    bool kept() const { return !offset.empty(); }
    // Bytes of `candidates` candidates over `tiles` tiles: the estimate before keeping them and
    // the count after are the same formula.
    static double bytes_for(std::size_t candidates, std::size_t tiles) {
      return static_cast<double>(candidates) * (sizeof(int) + detail::kTileRows * sizeof(double)) +
             static_cast<double>(tiles) * detail::kTileRows * sizeof(double) + static_cast<double>(tiles + 1) * sizeof(std::size_t);
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

// The products' rows go R = 4 at a time (a tile: consecutive items of one grid cell, in Morton order
// there, so a few h apart), over candidates that hold all their neighbours: each candidate's
// values are then loaded once for 4 rows instead of once a row (with one row at a time, the
// loads of the neighbours' values, 256 bytes each for 32 columns, bounded the loop), and its
// position once for 4 rows' distances. A row's weight is 0 at the candidates outside its own
// cut. Every row's sums run in a fixed order (the candidates' order, in lanes of 8 added in a
// fixed order), whatever the thread that computes them.

// out_r[0, V * 8) = sum_k w_r[k] x_{col_k}[0, V * 8) for the R rows of a tile, the R V sums held
// in registers (with a run-time width they were loaded and stored back for every neighbour).
// x stored row by row, `stride` values a row.
template <int R, int V>
__attribute__((always_inline)) inline void accumulate_tile(const double* const* w, const int* col, Eigen::Index count, const double* x,
                                                          Eigen::Index stride, double* const* out) {
  Lanes8 sum[R][V] = {};
  for (Eigen::Index k = 0; k < count; ++k) {
    const Lanes8u* xj = reinterpret_cast<const Lanes8u*>(x + static_cast<std::ptrdiff_t>(col[k]) * stride);
    Lanes8 xv[V];
    for (int v = 0; v < V; ++v) xv[v] = xj[v];
    for (int r = 0; r < R; ++r) {
      const double wk = w[r][k];  // scalar times vector: one broadcast
      for (int v = 0; v < V; ++v) sum[r][v] += wk * xv[v];
    }
  }
  for (int r = 0; r < R; ++r)
    for (int v = 0; v < V; ++v) *reinterpret_cast<Lanes8u*>(out[r] + 8 * v) = sum[r][v];
}

template <int R>
__attribute__((always_inline)) inline void accumulate_rows(const double* const* w, const int* col, Eigen::Index count, const double* x,
                                                          Eigen::Index b, double* const* out, bool wide) {
  double* o[R];
  Eigen::Index c = 0;
  auto pass = [&](auto columns) {  // columns: V * 8 of them, from c
    for (int r = 0; r < R; ++r) o[r] = out[r] + c;
    accumulate_tile<R, decltype(columns)::value / 8>(w, col, count, x + c, b, o);
    c += decltype(columns)::value;
  };
  // AVX-512: 32 columns a pass (R x 4 registers of sums, of 32); else 8 (R x 2 of 16 AVX2 ones).
  if (wide)
    for (; c + 32 <= b;) pass(std::integral_constant<int, 32>{});
  for (; c < b;) pass(std::integral_constant<int, 8>{});
}

// Fewer than 8 columns, unpadded (b values a row): for each column, 8 partial sums a row over
// the neighbours 8 at a time, then added in a fixed order (one sum a row was a chain of
// dependent additions, 4 cycles a neighbour).
template <int R>
__attribute__((always_inline)) inline void accumulate_narrow(const double* const* w, const int* col, Eigen::Index count, const double* x,
                                                            Eigen::Index b, double* const* out) {
  for (Eigen::Index c = 0; c < b; ++c) {
    Lanes8 partial[R] = {};
    Eigen::Index k = 0;
    for (; k + 8 <= count; k += 8) {
      Lanes8 xv;
      for (int l = 0; l < 8; ++l) xv[l] = x[static_cast<std::ptrdiff_t>(col[k + l]) * b + c];
      for (int r = 0; r < R; ++r) partial[r] += *reinterpret_cast<const Lanes8u*>(w[r] + k) * xv;
    }
    for (int r = 0; r < R; ++r) {
      double sum = 0;
      for (int l = 0; l < 8; ++l) sum += partial[r][l];
      for (Eigen::Index j = k; j < count; ++j) sum += w[r][j] * x[static_cast<std::ptrdiff_t>(col[j]) * b + c];
      out[r][c] = sum;
    }
  }
}

// out_r[0, b) = sum_k w_r[k] x_{col_k}[0, b) for the `rows` rows of a tile, x stored row by row,
// b values a row: the products' hot loop. A block of 8 columns or more comes padded with zeros
// to a multiple of 8. Fewer than 8 columns (a heat step, one product of the convergence sweep)
// are not padded, so that a neighbour's values share its cache line with the next ones. Each
// sum in a fixed order for a given build (AVX-512, AVX2 or baseline, chosen at run time; the
// same CPU always runs the same build, so results do not depend on the threads).
constexpr Eigen::Index kLanes = 8;
Eigen::Index padded_columns(Eigen::Index b) { return b < kLanes ? b : (b + kLanes - 1) / kLanes * kLanes; }
const bool kWideVectors = __builtin_cpu_supports("avx512f");

__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void accumulate_tile_rows(
    const double* const* w, int rows, const int* col, Eigen::Index count, const double* x, Eigen::Index b, double* const* out) {
  if (b < kLanes) {
    switch (rows) {
      case 4: accumulate_narrow<4>(w, col, count, x, b, out); break;
      case 3: accumulate_narrow<3>(w, col, count, x, b, out); break;
      case 2: accumulate_narrow<2>(w, col, count, x, b, out); break;
      default: accumulate_narrow<1>(w, col, count, x, b, out); break;
    }
    return;
  }
  switch (rows) {
    case 4: accumulate_rows<4>(w, col, count, x, b, out, kWideVectors); break;
    case 3: accumulate_rows<3>(w, col, count, x, b, out, kWideVectors); break;
    case 2: accumulate_rows<2>(w, col, count, x, b, out, kWideVectors); break;
    default: accumulate_rows<1>(w, col, count, x, b, out, kWideVectors); break;
  }
}

// A row's weights on the tile's candidates: w_k mu_k where its chord is within the cut and k is
// not the row itself, 0 elsewhere; returns their sum (8 partial sums, then added in a fixed
// order: the same bits whatever the thread).
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) double masked_weights(
    double* __restrict w, const double* __restrict chord2, const double* __restrict mass, const int* __restrict col, std::size_t count,
    double cut2, int self) {
  for (std::size_t k = 0; k < count; ++k) w[k] = chord2[k] <= cut2 && col[k] != self ? w[k] * mass[k] : 0.0;
  Lanes8 partial = {};
  std::size_t k = 0;
  for (; k + 8 <= count; k += 8) {
    Lanes8 v;
    std::memcpy(&v, w + k, sizeof(v));
    partial += v;
  }
  double sum = 0;
  for (int l = 0; l < 8; ++l) sum += partial[l];
  for (; k < count; ++k) sum += w[k];
  return sum;
}

// For each tile of up to kTileRows consecutive grid items [first, first + rows) of a part,
// f(tile, first, rows, col, w, sum, count): candidates that hold the union of their neighbours within
// the cut (as grid positions, in the grid's order), each row's weights w[r][k] = w_ik mu_k on
// them (0 outside the row's cut and on its own column) and their sums: the terms the assembled
// row holds. The candidates are the grid's within the cut plus the tile's radius of its centre
// (surfel_tiles.hpp), so that the kernel's distances (the intrinsic one: 20 operations) and the
// Gaussians are computed for few more than the neighbours (a torus at h = 0.025: the grid's
// cells offered 1.5 times the tile's neighbours).
template <class Part, class F>
void for_each_tile(const Part& part, F&& f) {
  const detail::Grid& grid = part.grid;
  const detail::Kernel& kernel = part.kernel;
  const double cut2 = kernel.cut * kernel.cut;
  const bool intrinsic = part.intrinsic();
#pragma omp parallel
  {
    detail::TileBuffer buffer;  // this thread's
#pragma omp for schedule(dynamic, 16)
    for (Eigen::Index tile = 0; tile < part.tiles.size(); ++tile) {
      const Eigen::Index first = part.tiles.first(tile);
      const int rows = part.tiles.rows(tile);
      const std::size_t count = detail::gather_tile_candidates(grid, first, rows, kernel.cut, part.mass_in_grid.data(), buffer);
      double sum[detail::kTileRows];
      double* w[detail::kTileRows];
      for (int r = 0; r < rows; ++r) {
        const auto at = static_cast<std::size_t>(first + r);
        const double q[3] = {grid.xs[at], grid.ys[at], grid.zs[at]};
        double* chord2 = buffer.chord2[r].data();
        w[r] = buffer.d2[r].data();
        if (intrinsic) {
          const double nq[3] = {grid.nxs[at], grid.nys[at], grid.nzs[at]};
          detail::intrinsic_distances(buffer.x.data(), buffer.y.data(), buffer.z.data(), buffer.nx.data(), buffer.ny.data(),
                                      buffer.nz.data(), count, q, nq, chord2, w[r]);
        } else {
          for (std::size_t k = 0; k < count; ++k) {
            const double dx = buffer.x[k] - q[0], dy = buffer.y[k] - q[1], dz = buffer.z[k] - q[2];
            chord2[k] = w[r][k] = dx * dx + dy * dy + dz * dz;
          }
        }
        gaussian_weights_wide(w[r], static_cast<Eigen::Index>(count), kernel.inv_4t, kernel.scale);
        sum[r] = masked_weights(w[r], chord2, buffer.value.data(), buffer.col.data(), count, cut2, static_cast<int>(at));
      }
      f(tile, first, rows, buffer.col.data(), static_cast<const double* const*>(w), sum, static_cast<Eigen::Index>(count));
    }
  }
}

// The same from the weights kept (Part::stored): the same arguments, bit for bit.
template <class Part, class F>
void for_each_stored_tile(const Part& part, F&& f) {
  const auto& stored = part.stored;
#pragma omp parallel for schedule(dynamic, 16)
  for (Eigen::Index tile = 0; tile < part.tiles.size(); ++tile) {
    const auto t = static_cast<std::size_t>(tile);
    const std::size_t begin = stored.offset[t], count = stored.offset[t + 1] - begin;
    const int rows = part.tiles.rows(tile);
    const double* w[detail::kTileRows];
    for (int r = 0; r < rows; ++r) w[r] = stored.weight.data() + detail::kTileRows * begin + static_cast<std::size_t>(r) * count;
    f(tile, part.tiles.first(tile), rows, stored.col.data() + begin, static_cast<const double* const*>(w),
      stored.sum.data() + detail::kTileRows * t, static_cast<Eigen::Index>(count));
  }
}

// Keeps a part's weights (Part::stored) when they take at most `budget` bytes; returns the
// bytes kept. One pass counts each tile's candidates (its weights are the Gaussians of the
// diagonal's pass: the same), a second copies them into place.
template <class Part>
double store_weights(Part& part, const std::vector<std::size_t>& candidates, double budget) {
  const std::size_t tiles = candidates.size();
  std::vector<std::size_t> offset(tiles + 1, 0);
  for (std::size_t t = 0; t < tiles; ++t) offset[t + 1] = offset[t] + candidates[t];
  if (tiles == 0 || Part::StoredTiles::bytes_for(offset.back(), tiles) > budget) return 0;
  auto& stored = part.stored;
  stored.col.resize(offset.back());
  stored.weight.resize(detail::kTileRows * offset.back());
  stored.sum.assign(detail::kTileRows * tiles, 0.0);
  for_each_tile(part, [&](Eigen::Index tile, Eigen::Index, int rows, const int* col, const double* const* w, const double* sum,
                          Eigen::Index count) {
    const auto t = static_cast<std::size_t>(tile), n = static_cast<std::size_t>(count);
    std::copy(col, col + n, stored.col.begin() + static_cast<std::ptrdiff_t>(offset[t]));
    for (int r = 0; r < rows; ++r) {
      std::copy(w[r], w[r] + n, stored.weight.begin() + static_cast<std::ptrdiff_t>(detail::kTileRows * offset[t] + static_cast<std::size_t>(r) * n));
      stored.sum[detail::kTileRows * t + static_cast<std::size_t>(r)] = sum[r];
    }
  });
  stored.offset = std::move(offset);
  return stored.bytes();
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
    part_.push_back(std::make_unique<Part>(first, positions.middleRows(first, rows), layout.kernel[p], mass_, intrinsic ? &normals : nullptr));
    Part& part = *part_.back();
    // The diagonal and row sums from the products' own tiles and sums (the same bits as the
    // diagonal term of a product; faster than a row at a time).
    std::vector<std::size_t> candidates(static_cast<std::size_t>(part.tiles.size()));
    for_each_tile(part, [&](Eigen::Index tile, Eigen::Index tile_first, int tile_rows, const int*, const double* const*,
                            const double* sum, Eigen::Index count) {
      candidates[static_cast<std::size_t>(tile)] = static_cast<std::size_t>(count);
      for (int r = 0; r < tile_rows; ++r) {
        const Eigen::Index it = tile_first + r, i = first + part.grid.items[static_cast<std::size_t>(it)];
        l_row_sums_[i] = part.row_scale[it] * sum[r];
        a_diagonal_[i] = -part.mass_in_grid[it] * sum[r];
      }
    });
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
  if (p >= part_.size()) throw Error("MatrixFreeSurfaceOperator: surface " + std::to_string(p) + " does not exist");
  const Part& part = *part_[p];
  if (x.rows() != part.rows)
    throw Error("MatrixFreeSurfaceOperator: a block of " + std::to_string(x.rows()) + " rows for a surface of " +
                std::to_string(part.rows));
  const Eigen::Index b = x.cols();
  // Each row's b values contiguous (the inner loop runs over them), from 8 on padded with zeros
  // to a multiple of 8, rows in the grid's order (a row's neighbours are then a few runs of
  // memory).
  const Eigen::Index padded = padded_columns(b);
  // Both blocks on huge pages, asked for before they are written: every product allocates them
  // afresh, and faulting 4 KiB pages in was about a tenth of a torus's spectrum (h = 0.025, 67,000
  // faults; docs/benchmarks.md).
  Eigen::MatrixXd xg, yt;  // yt: in the grid's order too
  digilap::detail::resize_on_huge_pages(xg, padded, part.rows);
  for (Eigen::Index it = 0; it < part.rows; ++it) {
    xg.col(it).head(b) = x.row(part.grid.items[static_cast<std::size_t>(it)]).transpose();
    xg.col(it).tail(padded - b).setZero();
  }
  digilap::detail::resize_on_huge_pages(yt, padded, part.rows);
  const double* mass = part.mass_in_grid.data();
  auto rows_of_tile = [&](Eigen::Index, Eigen::Index first, int rows, const int* col, const double* const* w, const double* sum,
                          Eigen::Index count) {
    // L_ij = w_ij mu_j off the diagonal, L_ii = -sum of them: the assembled row.
    double* out[detail::kTileRows];
    for (int r = 0; r < rows; ++r) out[r] = yt.col(first + r).data();
    accumulate_tile_rows(w, rows, col, count, xg.data(), padded, out);
    for (int r = 0; r < rows; ++r) {
      const Eigen::Index it = first + r;
      const double* xi = xg.col(it).data();
      const double scale = stiffness ? mass[it] : part.row_scale[it];
      for (Eigen::Index c = 0; c < b; ++c) out[r][c] = scale * (out[r][c] - sum[r] * xi[c]);
    }
  };
  if (part.stored.kept()) for_each_stored_tile(part, rows_of_tile);
  else for_each_tile(part, rows_of_tile);
  digilap::detail::resize_on_huge_pages(y, part.rows, b);
  for (Eigen::Index it = 0; it < part.rows; ++it) y.row(part.grid.items[static_cast<std::size_t>(it)]) = yt.col(it).head(b).transpose();
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
  // The solves 8 columns at a time over the threads (core/block_ldlt.hpp).
  void apply(const Eigen::MatrixXd& x, Eigen::MatrixXd& y) const {
    solver_.solve(root_mass_.asDiagonal() * x, y);
    y = scale_ * (root_mass_.asDiagonal() * y) + t_ * x;
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

// One surface's spectrum on the rows of positive area (`support`, local to the surface).
Spectrum part_spectrum(const MatrixFreeSurfaceOperator& op, std::size_t p, const std::vector<Eigen::Index>& support, int count,
                       const SpectrumOptions& o) {
  const Eigen::Index first = op.row_offset()[p], rows = op.row_offset()[p + 1] - first, n = static_cast<Eigen::Index>(support.size());
  Eigen::VectorXd mass(n), s(n);
  for (Eigen::Index r = 0; r < n; ++r) mass[r] = op.mass()[first + support[r]], s[r] = 1 / std::sqrt(mass[r]);
  // -A on the support: x scattered onto the surface's rows (zero off the support, where A's
  // columns vanish anyway), multiplied, and gathered back.
  Eigen::MatrixXd full, image;
  auto minus_a = [&](const Eigen::MatrixXd& x, Eigen::MatrixXd& y) {
    digilap::detail::resize_on_huge_pages(full, rows, x.cols());
    full.setZero();
    for (Eigen::Index r = 0; r < n; ++r) full.row(support[r]) = x.row(r);
    op.apply_part(p, full, image, true);
    digilap::detail::resize_on_huge_pages(y, n, x.cols());
    for (Eigen::Index r = 0; r < n; ++r) y.row(r) = -image.row(support[r]);
  };
  if (n <= digilap::detail::kDenseRows || 2 * count + 1 > n) {
    constexpr Eigen::Index kDenseLastResort = 3000;
    if (n > kDenseLastResort)
      throw Error("smallest_eigenpairs: " + std::to_string(count) + " eigenpairs of a surface of " + std::to_string(n) +
                  " surfels is more than half of them; ask for fewer");
    Eigen::MatrixXd minus_a_dense;
    minus_a(Eigen::MatrixXd::Identity(n, n), minus_a_dense);
    return digilap::detail::dense_spectrum(-minus_a_dense, mass, count);
  }
  const Eigen::Index block = digilap::detail::lobpcg_block(n, count);
  if (digilap::detail::lobpcg_bytes(n, block) + op.bytes() > o.memory_limit_bytes) {
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
  Eigen::MatrixXd scaled;
  auto apply_c = [&](const Eigen::MatrixXd& x, Eigen::MatrixXd& y) {
    digilap::detail::resize_on_huge_pages(scaled, x.rows(), x.cols());
    scaled.noalias() = s.asDiagonal() * x;
    minus_a(scaled, y);
    y = s.asDiagonal() * y;
  };
  // Preconditioned first (16-20 iterations on smooth surfaces, against 30-50 without). On
  // some thin real structures (a tract one or two voxels thick, whose graph joins opposite
  // sides) it stalls: after 150 iterations, the unpreconditioned iteration the assembled
  // operator uses takes over, from the start again.
  const int preconditioned_iterations = std::min(o.max_iterations, 150);
  digilap::detail::LobpcgResult result = digilap::detail::lobpcg(
      apply_c, [&](const Eigen::MatrixXd& x, Eigen::MatrixXd& y) { preconditioner.apply(x, y); },
      digilap::detail::lobpcg_start(n, block), count, o.tolerance * c, preconditioned_iterations, o.progress);
  if (!result.converged) {
    const int spent = result.products;
    result = digilap::detail::lobpcg(
        apply_c, [](const Eigen::MatrixXd& x, Eigen::MatrixXd& y) { y = x; }, digilap::detail::lobpcg_start(n, block), count,
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
  if (op.t() > 0) digilap::detail::laplace_beltrami_by_contour(s, op.row_offset(), op.part_t());
  return s;
}

}  // namespace digilap::surface
