#include "digilap/surface/heat_laplacian.hpp"

#include "digilap/error.hpp"
#include "../row_assembly.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>

namespace digilap::surface {

namespace {
constexpr double kPi = 3.14159265358979323846;

// Uniform grid over the surfel centres, cell = half the cut (coarser when that would make more
// than about 8 cells per surfel), items sorted by row within each cell, with their coordinates
// stored contiguously in the same order: the search reads memory in sequence (reading rows of
// the column-major position matrix made it cache-bound).
struct Grid {
  Eigen::Vector3d origin;
  double cell = 1;
  int reach = 2;  // cells scanned on each side: ceil(cut / cell)
  Eigen::Index nx = 1, ny = 1, nz = 1;
  std::vector<Eigen::Index> start, items;
  std::vector<Eigen::Vector3d> xyz;

  Grid(const Eigen::MatrixX3d& p, double cut) {
    const Eigen::Index n = p.rows();
    origin = p.colwise().minCoeff().transpose();
    const Eigen::Vector3d extent = p.colwise().maxCoeff().transpose() - origin;
    cell = 0.5 * cut;
    while ((extent.x() / cell + 1) * (extent.y() / cell + 1) * (extent.z() / cell + 1) > 8.0 * static_cast<double>(n) + 64) cell *= 2;
    nx = static_cast<Eigen::Index>(extent.x() / cell) + 1;
    ny = static_cast<Eigen::Index>(extent.y() / cell) + 1;
    nz = static_cast<Eigen::Index>(extent.z() / cell) + 1;
    start.assign(static_cast<std::size_t>(nx * ny * nz + 1), 0);
    for (Eigen::Index r = 0; r < n; ++r) ++start[static_cast<std::size_t>(cell_of(p.row(r)) + 1)];
    std::partial_sum(start.begin(), start.end(), start.begin());
    items.resize(static_cast<std::size_t>(n));
    std::vector<Eigen::Index> fill(start.begin(), start.end() - 1);
    for (Eigen::Index r = 0; r < n; ++r) items[static_cast<std::size_t>(fill[static_cast<std::size_t>(cell_of(p.row(r)))]++)] = r;
    reach = static_cast<int>(std::ceil(cut / cell));
    xyz.resize(items.size());
    for (std::size_t it = 0; it < items.size(); ++it) xyz[it] = p.row(items[it]).transpose();
  }
  Eigen::Index index(double v, double o, Eigen::Index count) const {
    return std::clamp<Eigen::Index>(static_cast<Eigen::Index>((v - o) / cell), 0, count - 1);
  }
  Eigen::Index cell_of(const Eigen::RowVector3d& q) const {
    return (index(q.z(), origin.z(), nz) * ny + index(q.y(), origin.y(), ny)) * nx + index(q.x(), origin.x(), nx);
  }
  // f(j) for every j != i within `cut` of row i (in cell order). The distance is computed as
  // the assembly computes it, so that both passes and both (i, j) and (j, i) agree bit for bit.
  template <class F>
  void for_neighbours(const Eigen::MatrixX3d& p, Eigen::Index i, double cut, F&& f) const {
    const Eigen::Vector3d q = p.row(i).transpose();
    const Eigen::Index cx = index(q.x(), origin.x(), nx), cy = index(q.y(), origin.y(), ny), cz = index(q.z(), origin.z(), nz);
    const double cut2 = cut * cut;
    for (Eigen::Index z = std::max<Eigen::Index>(0, cz - reach); z <= std::min(nz - 1, cz + reach); ++z)
      for (Eigen::Index y = std::max<Eigen::Index>(0, cy - reach); y <= std::min(ny - 1, cy + reach); ++y) {
        const Eigen::Index row = (z * ny + y) * nx;
        const Eigen::Index first = start[static_cast<std::size_t>(row + std::max<Eigen::Index>(0, cx - reach))];
        const Eigen::Index last = start[static_cast<std::size_t>(row + std::min(nx - 1, cx + reach) + 1)];
        for (Eigen::Index it = first; it < last; ++it) {  // the cells of one x-row are contiguous
          const Eigen::Vector3d& o = xyz[static_cast<std::size_t>(it)];
          const double dx = o.x() - q.x(), dy = o.y() - q.y(), dz = o.z() - q.z();
          if (dx * dx + dy * dy + dz * dz <= cut2 && items[static_cast<std::size_t>(it)] != i) f(items[static_cast<std::size_t>(it)]);
        }
      }
  }
};
}  // namespace

SurfaceOperator heat_laplacian(const SurfelSet& surfels, const SurfelMeasures& measures, const HeatLaplacianOptions& options) {
  if (options.richardson) throw Error("heat_laplacian (surfaces): Richardson extrapolation is not available in 3D");
  const auto n = static_cast<Eigen::Index>(surfels.size());
  if (measures.mu.size() != n)
    throw Error("heat_laplacian (surfaces): " + std::to_string(measures.mu.size()) + " measures for " + std::to_string(n) + " surfels");
  require_positive("heat_laplacian (surfaces): k", options.k);
  SurfaceOperator op;
  op.t = heat_time(surfels.h, options, measures.length_scale);
  op.length_scale = options.t != 0 ? 0.0 : (options.length_scale != 0 ? options.length_scale : measures.length_scale);
  op.cut = options.k * std::sqrt(op.t);
  op.positions = surfels.centres();
  op.mass = measures.mu;
  const double inv_4t = 1 / (4 * op.t), scale = 1 / (4 * kPi * op.t * op.t);  // 1 / (t (4 pi t)^(d/2)), d = 2
  if (n == 0) return op;
  const Grid grid(op.positions, op.cut);
  std::vector<Eigen::Index> row_nnz(static_cast<std::size_t>(n));
#pragma omp parallel for schedule(dynamic, 256)
  for (Eigen::Index i = 0; i < n; ++i) {
    Eigen::Index count = 1;
    grid.for_neighbours(op.positions, i, op.cut, [&](Eigen::Index) { ++count; });
    row_nnz[static_cast<std::size_t>(i)] = count;
  }
  const auto nnz = static_cast<std::size_t>(std::accumulate(row_nnz.begin(), row_nnz.end(), Eigen::Index(0)));
  const double bytes = heat_laplacian_bytes(nnz, static_cast<std::size_t>(n), options.stiffness);
  if (bytes > options.memory_limit_bytes || nnz > static_cast<std::size_t>(std::numeric_limits<int>::max())) {
    std::ostringstream msg;
    msg << "heat_laplacian (surfaces): the operator would take about " << bytes / 1e9 << " GB (" << nnz
        << " nonzeros per matrix, " << n << " rows), above the memory limit of " << options.memory_limit_bytes / 1e9
        << " GB (or 2^31 nonzeros); raise memory_limit_bytes, use a coarser h, or a smaller t or k";
    throw Error(msg.str());
  }
  detail::allocate(op.L, n, row_nnz);
  if (options.stiffness) detail::allocate(op.A, n, row_nnz);
  SparseMatrix* stiffness = options.stiffness ? &op.A : nullptr;
#pragma omp parallel for schedule(dynamic, 64)
  for (Eigen::Index i = 0; i < n; ++i) {
    const int begin = op.L.outerIndexPtr()[i], count = op.L.outerIndexPtr()[i + 1] - begin;
    int* col = op.L.innerIndexPtr() + begin;
    double* d2 = op.L.valuePtr() + begin;
    int k = 0;
    col[k++] = static_cast<int>(i);
    grid.for_neighbours(op.positions, i, op.cut, [&](Eigen::Index j) { col[k++] = static_cast<int>(j); });
    std::sort(col, col + count);
    Eigen::Index diag = 0;
    for (k = 0; k < count; ++k) {
      // The same expression for (i, j) and (j, i): the same bits, A symmetric.
      const double dx = op.positions(col[k], 0) - op.positions(i, 0), dy = op.positions(col[k], 1) - op.positions(i, 1),
                   dz = op.positions(col[k], 2) - op.positions(i, 2);
      d2[k] = dx * dx + dy * dy + dz * dz;
      if (col[k] == i) diag = k;
    }
    detail::finish_row(op.L, stiffness, i, diag, op.mass, inv_4t, scale);
  }
  op.M.resize(n, n);
  op.M.reserve(Eigen::VectorXi::Ones(n));
  for (Eigen::Index r = 0; r < n; ++r) op.M.insert(r, r) = op.mass[r];
  op.M.makeCompressed();
  return op;
}

}  // namespace digilap::surface
