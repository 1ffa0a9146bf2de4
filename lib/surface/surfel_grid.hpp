// Internal: the neighbour search of the surface operator, shared by the assembled operator
// (heat_laplacian.cpp) and the matrix-free products (matrix_free.cpp): a uniform grid over the
// surfel centres, a row's neighbours within the cut in a fixed order, and the kernel of one
// heat time.
#pragma once

#include "digilap/core/error.hpp"
#include "digilap/core/constants.hpp"
#include "digilap/surface/heat_laplacian.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <sstream>
#include <utility>
#include <vector>

namespace digilap::surface::detail {


// The squared distances of SurfaceKernel::Intrinsic from q (normal nq) to `count` consecutive
// grid items (coordinates x, y, z, normals nx, ny, nz), with their chords: for each, with the
// chord d = x_j - x_i, the normals' sum s = n_i + n_j and difference e = n_j - n_i, the chord in
// the mean tangent plane plus the second-order geodesic term,
//   |d|^2 - <d, s>^2 / |s|^2 + <d, e>^2 / 12,
// or the chord when the normals are more than 90 degrees apart (|s|^2 <= 2: two sides of a thin
// wall, where no tangent plane is shared). Swapping i and j negates d and e exactly and leaves s
// unchanged (addition commutes), so the result is the same bit for bit: A stays symmetric.
// Built for AVX-512, AVX2 and the baseline, the CPU's best picked at load time, and without
// contracting products into FMAs, so that every build gives the same bits (surfel_grid.cpp).
void intrinsic_distances(const double* x, const double* y, const double* z, const double* nx, const double* ny, const double* nz,
                         std::size_t count, const double* q, const double* nq, double* chord2, double* d2);
// The same for the products' upper triangle (matrix_free.cpp), one row of a tile against its
// candidates (grid positions col): d2 alone, +infinity where the chord is beyond the cut or the
// candidate is not after the row (col <= self), whose weight the kernel's exp then makes exactly
// 0 (core/gaussian_kernel.cpp). One pass where a pass writing the chords and one reading them
// back to zero those weights took 3-4% of a product.
void upper_intrinsic_distances(const double* x, const double* y, const double* z, const double* nx, const double* ny,
                               const double* nz, const int* col, std::size_t count, const double* q, const double* nq, double cut2,
                               int self, double* d2);

namespace {
// 1 / s without a double division, for the intrinsic kernel's |s|^2 (in (2, 4], or 1): a vector
// double division takes 16 cycles for 8 values on an Intel Ice Lake server, and the two of
// intrinsic_distances (this one and a division by 12) were two thirds of its time, a tenth of a
// surface spectrum's (docs/benchmarks.md). A float division (24 correct bits, the same on every
// CPU: IEEE rounds it exactly), then two Newton steps, each doubling the correct bits, the last
// written as a correction y + y (1 - s y), which rounds closer than y (2 - s y) (within 1.25 ulp
// of 1 / s over 4 million values against 1.97). Only for the files built without FMA
// contraction (surfel_grid.cpp, intrinsic_kernel.cpp: lib/CMakeLists.txt), whose clones then
// round alike; internal linkage, so that each of them has its own copy built with its flags.
inline double reciprocal_of_normals_sum(double s) {
  double y = static_cast<double>(1.0f / static_cast<float>(s));
  y = y * (2.0 - s * y);
  return y + y * (1.0 - s * y);
}

// Candidate u against q (normal nq), the start of both the intrinsic distance
// (intrinsic_distances) and the curvature pass's tangent chord (intrinsic_kernel.cpp), written
// once so that the two give the same bits: the chord d = x_u - q, |d|^2, and the chord in the mean
// tangent plane |d|^2 - <d, s>^2 / |s|^2 (s = n_u + nq) where the normals share one (`shared`,
// |s|^2 > 2: less than 90 degrees apart; elsewhere rho2 is not that and is not used). Like
// reciprocal_of_normals_sum, only for the files built without FMA contraction.
struct TangentChord {
  double dx, dy, dz, chord2, rho2;
  bool shared;
};
__attribute__((always_inline)) inline TangentChord tangent_chord(const double* __restrict x, const double* __restrict y,
                                                                const double* __restrict z, const double* __restrict nx,
                                                                const double* __restrict ny, const double* __restrict nz, std::size_t u,
                                                                const double* q, const double* nq) {
  TangentChord t;
  t.dx = x[u] - q[0], t.dy = y[u] - q[1], t.dz = z[u] - q[2];
  const double sx = nx[u] + nq[0], sy = ny[u] + nq[1], sz = nz[u] + nq[2];
  t.chord2 = t.dx * t.dx + t.dy * t.dy + t.dz * t.dz;
  const double s2 = sx * sx + sy * sy + sz * sz, height = t.dx * sx + t.dy * sy + t.dz * sz;
  t.shared = s2 > 2;
  t.rho2 = t.chord2 - height * height * reciprocal_of_normals_sum(t.shared ? s2 : 1.0);
  return t;
}
}  // namespace

// A row's columns and squared distances, before sorting (one per thread, reused).
struct RowBuffer {
  std::vector<int> col;
  std::vector<double> d2;
  std::size_t size = 0;
  std::vector<double> run_chord2, run_d2;  // one run of candidates (the intrinsic gather)
  void reserve(std::size_t n) {
    if (col.size() < n) col.resize(2 * n), d2.resize(2 * n);
  }
};

// Uniform grid over the surfel centres, cell = a quarter of the cut (coarser when that would
// make more than about 8 cells per surfel), items sorted by row within each cell, with their
// coordinates stored contiguously in the same order, one array per axis: the search reads
// memory in sequence (reading rows of the column-major position matrix made it cache-bound).
struct Grid {
  Eigen::Vector3d origin;
  double cell = 1;
  int reach = 4;  // cells scanned on each side: ceil(cut / cell)
  Eigen::Index nx = 1, ny = 1, nz = 1;
  // The cells' order: by `axis[2]` (the slowest), then axis[1], then axis[0] (the fastest, whose
  // cells are contiguous in the item order). z, y, x unless built with longest_slowest.
  int axis[3] = {0, 1, 2};
  Eigen::Index count(int a) const { return a == 0 ? nx : a == 1 ? ny : nz; }
  /// Layers of cells along the slowest axis, and the cells of one.
  Eigen::Index layers() const { return count(axis[2]); }
  Eigen::Index cells_per_layer() const { return count(axis[0]) * count(axis[1]); }
  std::vector<Eigen::Index> start, items;
  std::vector<double> xs, ys, zs;

  // With `normals` (one row per point, SurfaceKernel::Intrinsic), gather_within can give the
  // intrinsic distance instead of the chord; they are kept in the item order too.
  std::vector<double> nxs, nys, nzs;

  // longest_slowest: the slowest axis along the points' longest extent, so that there are more
  // layers (the matrix-free products go layer by layer).
  Grid(const Eigen::MatrixX3d& p, double cut, const Eigen::MatrixX3d* normals = nullptr, double cells_per_cut = 4,
       bool longest_slowest = false) {
    const Eigen::Index n = p.rows();
    origin = p.colwise().minCoeff().transpose();
    const Eigen::Vector3d extent = p.colwise().maxCoeff().transpose() - origin;
    cell = cut / cells_per_cut;
    while ((extent.x() / cell + 1) * (extent.y() / cell + 1) * (extent.z() / cell + 1) > 8.0 * static_cast<double>(n) + 64) cell *= 2;
    Eigen::Index longest = 2;
    if (longest_slowest && n > 0 && extent.maxCoeff(&longest) > extent.z()) {  // z unless strictly shorter
      for (int a = 0, k = 0; a < 3; ++a)
        if (a != longest) axis[k++] = a;
      axis[2] = static_cast<int>(longest);
    }
    nx = static_cast<Eigen::Index>(extent.x() / cell) + 1;
    ny = static_cast<Eigen::Index>(extent.y() / cell) + 1;
    nz = static_cast<Eigen::Index>(extent.z() / cell) + 1;
    start.assign(static_cast<std::size_t>(nx * ny * nz + 1), 0);
    for (Eigen::Index r = 0; r < n; ++r) ++start[static_cast<std::size_t>(cell_of(p.row(r)) + 1)];
    std::partial_sum(start.begin(), start.end(), start.begin());
    items.resize(static_cast<std::size_t>(n));
    std::vector<Eigen::Index> fill(start.begin(), start.end() - 1);
    for (Eigen::Index r = 0; r < n; ++r) items[static_cast<std::size_t>(fill[static_cast<std::size_t>(cell_of(p.row(r)))]++)] = r;
    // Within a cell, items in Morton order of their position (at a 64th of the cell), ties by
    // row: consecutive items are then close in space in every direction (in row order they ran
    // along the surfels' scan line), so that a few consecutive rows share most neighbours (the
    // matrix-free products take rows 8 at a time).
    std::vector<std::pair<std::uint32_t, Eigen::Index>> keyed;
    for (std::size_t c = 0; c + 1 < start.size(); ++c) {
      const auto first = static_cast<std::size_t>(start[c]), last = static_cast<std::size_t>(start[c + 1]);
      if (last - first < 3) continue;
      keyed.clear();
      for (std::size_t it = first; it < last; ++it) {
        const Eigen::Index r = items[it];
        keyed.emplace_back(morton_in_cell(p.row(r)), r);
      }
      std::sort(keyed.begin(), keyed.end());
      for (std::size_t it = first; it < last; ++it) items[it] = keyed[it - first].second;
    }
    reach = static_cast<int>(std::ceil(cut / cell));
    xs.resize(items.size()), ys.resize(items.size()), zs.resize(items.size());
    for (std::size_t it = 0; it < items.size(); ++it) xs[it] = p(items[it], 0), ys[it] = p(items[it], 1), zs[it] = p(items[it], 2);
    if (normals) {
      nxs.resize(items.size()), nys.resize(items.size()), nzs.resize(items.size());
      for (std::size_t it = 0; it < items.size(); ++it)
        nxs[it] = (*normals)(items[it], 0), nys[it] = (*normals)(items[it], 1), nzs[it] = (*normals)(items[it], 2);
    }
  }
  // The Morton key of q's position inside its cell, 6 bits an axis (z, y, x interleaved).
  std::uint32_t morton_in_cell(const Eigen::RowVector3d& q) const {
    std::uint32_t key = 0;
    const double v[3] = {q.x() - origin.x(), q.y() - origin.y(), q.z() - origin.z()};
    for (int axis = 0; axis < 3; ++axis) {
      const double inside = v[axis] / cell - std::floor(v[axis] / cell);
      const auto bits = static_cast<std::uint32_t>(std::clamp(inside * 64, 0.0, 63.0));
      for (int b = 0; b < 6; ++b) key |= ((bits >> b) & 1u) << (3 * b + axis);
    }
    return key;
  }
  Eigen::Index index(double v, double o, Eigen::Index count) const {
    return std::clamp<Eigen::Index>(static_cast<Eigen::Index>((v - o) / cell), 0, count - 1);
  }
  Eigen::Index cell_along(const Eigen::RowVector3d& q, int a) const { return index(q[a], origin[a], count(a)); }
  Eigen::Index cell_of(const Eigen::RowVector3d& q) const {
    return (cell_along(q, axis[2]) * count(axis[1]) + cell_along(q, axis[1])) * count(axis[0]) + cell_along(q, axis[0]);
  }
  // f(first, last) for the item ranges that may hold points within `cut` of a point of the box
  // [lo, hi]: per row of cells along the fastest axis (x unless built with longest_slowest), the
  // cells of the ball's chord at the row's nearest point, widened by the box (a row's cells are
  // contiguous in the item order). A point's
  // ranges are the box's with lo = hi; a box's hold every one of its points' candidates, in the
  // same order.
  template <class F>
  void for_candidates(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double cut, F&& f) const {
    const int a = axis[0], b = axis[1], c = axis[2];  // fastest to slowest
    const Eigen::Index na = count(a), nb = count(b), nc = count(c);
    const Eigen::Index b0 = index(lo[b], origin[b], nb), b1 = index(hi[b], origin[b], nb);
    const Eigen::Index c0 = index(lo[c], origin[c], nc), c1 = index(hi[c], origin[c], nc);
    auto gap = [&](Eigen::Index k, double v0, double v1, double o) {  // distance from [v0, v1] to cell k's interval
      const double from = o + static_cast<double>(k) * cell;
      return v1 < from ? from - v1 : std::max(0.0, v0 - (from + cell));
    };
    for (Eigen::Index kc = std::max<Eigen::Index>(0, c0 - reach); kc <= std::min(nc - 1, c1 + reach); ++kc) {
      const double gc = gap(kc, lo[c], hi[c], origin[c]);
      for (Eigen::Index kb = std::max<Eigen::Index>(0, b0 - reach); kb <= std::min(nb - 1, b1 + reach); ++kb) {
        const double gb = gap(kb, lo[b], hi[b], origin[b]), chord2 = cut * cut - gc * gc - gb * gb;
        if (chord2 < 0) continue;
        const double chord = std::sqrt(chord2);
        const Eigen::Index row = (kc * nb + kb) * na;
        f(start[static_cast<std::size_t>(row + index(lo[a] - chord, origin[a], na))],
          start[static_cast<std::size_t>(row + index(hi[a] + chord, origin[a], na) + 1)]);
      }
    }
  }
  template <class F>
  void for_candidates(const Eigen::Vector3d& q, double cut, F&& f) const {
    for_candidates(q, q, cut, std::forward<F>(f));
  }
  // Squared distance from q to item `it`, as (x_j - x_i)^2 + (y_j - y_i)^2 + (z_j - z_i)^2:
  // the same bits for (i, j) and (j, i), since x_i - x_j = -(x_j - x_i) exactly, in both passes.
  double distance2(const Eigen::Vector3d& q, Eigen::Index it) const {
    const auto k = static_cast<std::size_t>(it);
    const double dx = xs[k] - q.x(), dy = ys[k] - q.y(), dz = zs[k] - q.z();
    return dx * dx + dy * dy + dz * dz;
  }
  // The number of points within `cut` of q, q's own included (branch-free).
  Eigen::Index count_within(const Eigen::Vector3d& q, double cut) const {
    Eigen::Index count = 0;
    const double cut2 = cut * cut;
    for_candidates(q, cut, [&](Eigen::Index first, Eigen::Index last) {
      Eigen::Index c = 0;
      for (Eigen::Index it = first; it < last; ++it) c += distance2(q, it) <= cut2;
      count += c;
    });
    return count;
  }
  // The points within `cut` of q (q's own included, at d2 = 0) appended to `found` with their
  // squared distances, in cell order. Branch-free: every candidate is written and the end moves
  // on when it is within the cut.
  // With in_grid_order, the columns are positions in the grid's item order instead of rows
  // (the matrix-free products keep their vectors in that order: neighbours are then close in
  // memory).
  // With a normal nq (the grid built with normals), the squared distances are the intrinsic
  // ones (intrinsic_distance2); the neighbours are still those within `cut` along the chord.
  void gather_within(const Eigen::Vector3d& q, double cut, RowBuffer& found, bool in_grid_order = false,
                     const Eigen::Vector3d* nq = nullptr) const {
    const double cut2 = cut * cut;
    found.size = 0;
    if (!nq) {
      for_candidates(q, cut, [&](Eigen::Index first, Eigen::Index last) {
        found.reserve(found.size + static_cast<std::size_t>(last - first));
        int* col = found.col.data();
        double* d2 = found.d2.data();
        std::size_t k = found.size;
        for (Eigen::Index it = first; it < last; ++it) {
          const double chord2 = distance2(q, it);
          col[k] = static_cast<int>(in_grid_order ? it : items[static_cast<std::size_t>(it)]), d2[k] = chord2;
          k += chord2 <= cut2;
        }
        found.size = k;
      });
      return;
    }
    // Intrinsic: the run's distances first, in a loop that vectorizes, then the compaction.
    for_candidates(q, cut, [&](Eigen::Index first, Eigen::Index last) {
      const auto count = static_cast<std::size_t>(last - first), u = static_cast<std::size_t>(first);
      found.reserve(found.size + count);
      if (found.run_d2.size() < count) found.run_d2.resize(2 * count), found.run_chord2.resize(2 * count);
      intrinsic_distances(&xs[u], &ys[u], &zs[u], &nxs[u], &nys[u], &nzs[u], count, q.data(), nq->data(), found.run_chord2.data(),
                          found.run_d2.data());
      int* col = found.col.data();
      double* d2 = found.d2.data();
      std::size_t k = found.size;
      for (std::size_t r = 0; r < count; ++r) {
        const std::size_t it = u + r;
        col[k] = static_cast<int>(in_grid_order ? it : static_cast<std::size_t>(items[it])), d2[k] = found.run_d2[r];
        k += found.run_chord2[r] <= cut2;
      }
      found.size = k;
    });
  }
};

// Sorts a row's distinct columns, all in [lo, hi], with their squared distances, by marking the
// columns in a bitmap over [lo, hi] (the distances parked at the same offsets) and reading it
// back in order: count + (hi - lo) / 64 steps against count log(count)
// for a comparison sort. A row holds thousands of columns over a range of a few thousand to N,
// so the bitmap is a few hundred words (docs/benchmarks.md has the assembly before and after).
class RowSorter {
public:
  /// Writes the row's columns in ascending order to col, with their distances to d2.
  void sort(const RowBuffer& row, int* col, double* d2) {
    const int* in = row.col.data();
    const auto count = static_cast<std::ptrdiff_t>(row.size);
    const int lo = *std::min_element(in, in + count), hi = *std::max_element(in, in + count);
    const std::size_t words = static_cast<std::size_t>(hi - lo) / 64 + 1;
    if (marks_.size() < words) marks_.resize(words, 0), parked_.resize(64 * words);
    for (std::ptrdiff_t k = 0; k < count; ++k) {
      const auto at = static_cast<std::size_t>(in[k] - lo);
      marks_[at / 64] |= std::uint64_t{1} << (at % 64);
      parked_[at] = row.d2[static_cast<std::size_t>(k)];
    }
    std::ptrdiff_t k = 0;
    for (std::size_t w = 0; w < words; ++w) {
      for (std::uint64_t bits = marks_[w]; bits != 0; bits &= bits - 1) {
        const std::size_t at = 64 * w + static_cast<std::size_t>(__builtin_ctzll(bits));
        col[k] = lo + static_cast<int>(at), d2[k++] = parked_[at];
      }
      marks_[w] = 0;
    }
  }

private:
  std::vector<std::uint64_t> marks_;
  std::vector<double> parked_;
};
// The kernel of one heat time: its cut, 1 / (4t) and prefactor 1 / (4 pi t^2), checked finite.
struct Kernel {
  double t, cut, inv_4t, scale;
  Kernel(double t_, double k) : t(t_), cut(k * std::sqrt(t_)), inv_4t(1 / (4 * t_)), scale(1 / (4 * kPi * t_ * t_)) {
    if (!std::isfinite(scale) || !std::isfinite(cut) || !std::isfinite(inv_4t)) {  // t from extreme h, l or c_t
      std::ostringstream msg;
      msg << "heat_laplacian (surfaces): the heat time t = " << t << " gives a kernel prefactor 1 / (4 pi t^2) = " << scale
          << " and a cut " << cut << ": one is not a finite number; give a t (or an h) in a usable range";
      throw Error(msg.str());
    }
  }
};


// The parts of a surface operator (its connected surfaces, or one part when they are coupled)
// and the kernel of each: what heat_laplacian and the matrix-free products both derive from
// the surfels, their measures and the options.
struct PartLayout {
  std::vector<Eigen::Index> row_offset;  ///< part p: rows [row_offset[p], row_offset[p + 1])
  std::vector<Kernel> kernel;            ///< one per part (one when there is none)
  double t = 0, cut = 0, length_scale = 0;  ///< of the largest part
  std::vector<double> part_t;
};
}  // namespace digilap::surface::detail

namespace digilap::surface {
detail::PartLayout part_layout(const SurfelSet& surfels, const SurfelMeasures& measures, const HeatLaplacianOptions& options);
}  // namespace digilap::surface
