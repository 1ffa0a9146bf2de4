#include "digilap/surface/heat_laplacian.hpp"

#include "digilap/core/error.hpp"
#include "core/row_assembly.hpp"
#include "intrinsic_kernel.hpp"
#include "surfel_grid.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <sstream>

namespace digilap::surface {

using detail::Grid;
using detail::Kernel;
using detail::PartLayout;
using detail::RowBuffer;
using detail::RowSorter;

PartLayout part_layout(const SurfelSet& surfels, const SurfelMeasures& measures, const HeatLaplacianOptions& options) {
  const auto n = static_cast<Eigen::Index>(surfels.size());
  PartLayout layout;
  // The parts: the connected surfaces, or all surfels together when they are coupled.
  if (options.couple_surfaces) {
    layout.row_offset = {0, n};
  } else {
    for (std::size_t offset : surfels.offsets()) layout.row_offset.push_back(static_cast<Eigen::Index>(offset));
  }
  const std::vector<Eigen::Index>& offset = layout.row_offset;
  const std::size_t parts = offset.size() - 1;
  // Each part's heat time: its own l_c as contours have, unless t or l is given or one is asked.
  const bool own_l = parts > 0 && !options.couple_surfaces && options.per_contour_time && options.t == 0 && options.length_scale == 0 &&
                     measures.surface_length_scales.size() == parts;
  for (std::size_t p = 0; p < parts; ++p)
    layout.kernel.emplace_back(heat_time(surfels.h, options, own_l ? measures.surface_length_scales[p] : measures.length_scale),
                               options.k);
  if (parts == 0) layout.kernel.emplace_back(heat_time(surfels.h, options, measures.length_scale), options.k);
  std::size_t largest = 0;  // the part with the most rows: its t is the operator's t
  for (std::size_t p = 0; p < parts; ++p)
    if (offset[p + 1] - offset[p] > offset[largest + 1] - offset[largest]) largest = p;
  layout.t = layout.kernel[largest].t;
  layout.cut = layout.kernel[largest].cut;
  layout.length_scale = options.t != 0              ? 0.0
                        : options.length_scale != 0 ? options.length_scale
                        : own_l                     ? measures.surface_length_scales[largest]
                                                    : measures.length_scale;
  for (std::size_t p = 0; p < parts; ++p) layout.part_t.push_back(layout.kernel[p].t);
  return layout;
}

SurfaceOperator heat_laplacian(const SurfelSet& surfels, const SurfelMeasures& measures, const HeatLaplacianOptions& options) {
  return detail::heat_laplacian_rows(surfels, measures, options, {});
}

// `wanted` empty: every row.
SurfaceOperator detail::heat_laplacian_rows(const SurfelSet& surfels, const SurfelMeasures& measures, const HeatLaplacianOptions& options,
                                            const std::vector<char>& wanted) {
  if (options.richardson) throw Error("heat_laplacian (surfaces): Richardson extrapolation is not available in 3D");
  const auto n = static_cast<Eigen::Index>(surfels.size());
  if (measures.mu.size() != n)
    throw Error("heat_laplacian (surfaces): " + std::to_string(measures.mu.size()) + " measures for " + std::to_string(n) + " surfels");
  require_positive("heat_laplacian (surfaces): k", options.k);
  SurfaceOperator op;
  op.positions = surfels.centres();
  op.mass = measures.mu;
  const PartLayout layout = part_layout(surfels, measures, options);
  op.row_offset = layout.row_offset;
  const std::vector<Kernel>& kernel = layout.kernel;
  const std::size_t parts = op.row_offset.size() - 1;
  op.t = layout.t;
  op.cut = layout.cut;
  op.length_scale = layout.length_scale;
  op.part_t = layout.part_t;
  if (!wanted.empty() && wanted.size() != static_cast<std::size_t>(n))
    throw Error("heat_laplacian (surfaces): " + std::to_string(wanted.size()) + " wanted flags for " + std::to_string(n) + " surfels");
  auto is_wanted = [&](Eigen::Index i) { return wanted.empty() || wanted[static_cast<std::size_t>(i)] != 0; };
  const bool intrinsic = options.surface_kernel == SurfaceKernel::Intrinsic;
  if (intrinsic) check_intrinsic_normals("heat_laplacian (surfaces)", measures, n);
  if (n == 0) return op;
  std::vector<Grid> grids;
  grids.reserve(parts);
  // The intrinsic kernel's weights' measures mu_i (1 + g_i) (intrinsic_kernel.hpp); the masses stay mu.
  Eigen::VectorXd weight_mu = op.mass, row_scale = Eigen::VectorXd::Ones(n);
  for (std::size_t p = 0; p < parts; ++p) {
    const Eigen::Index first = op.row_offset[p], rows = op.row_offset[p + 1] - first;
    if (!intrinsic) {
      grids.emplace_back(op.positions.middleRows(first, rows), kernel[p].cut);
      continue;
    }
    const Eigen::MatrixX3d normals = measures.normals.middleRows(first, rows);
    grids.emplace_back(op.positions.middleRows(first, rows), kernel[p].cut, &normals);
    const Eigen::VectorXd factor =
        detail::curvature_factors(grids.back(), op.positions.middleRows(first, rows), normals, op.mass.segment(first, rows), kernel[p]);
    row_scale.segment(first, rows) = factor;
    weight_mu.segment(first, rows) = op.mass.segment(first, rows).cwiseProduct(factor);
  }
  std::vector<Eigen::Index> row_nnz(static_cast<std::size_t>(n));
  for (std::size_t p = 0; p < parts; ++p) {
    const Eigen::Index first = op.row_offset[p], last = op.row_offset[p + 1];
#pragma omp parallel for schedule(dynamic, 256)
    for (Eigen::Index i = first; i < last; ++i)  // with the diagonal
      row_nnz[static_cast<std::size_t>(i)] = is_wanted(i) ? grids[p].count_within(op.positions.row(i).transpose(), kernel[p].cut) : 0;
  }
  const auto nnz = static_cast<std::size_t>(std::accumulate(row_nnz.begin(), row_nnz.end(), Eigen::Index(0)));
  digilap::detail::check_operator_memory("heat_laplacian (surfaces)", nnz, static_cast<std::size_t>(n), options.memory_limit_bytes,
                                options.stiffness, "use a smaller c_t, t or k (for a volume h only sets the units)");
  digilap::detail::allocate(op.L, n, row_nnz);
  if (options.stiffness) digilap::detail::allocate(op.A, n, row_nnz);
  SparseMatrix* stiffness = options.stiffness ? &op.A : nullptr;
  std::atomic<bool> mismatch{false};
  for (std::size_t p = 0; p < parts; ++p) {
    const Eigen::Index first = op.row_offset[p], last = op.row_offset[p + 1];
    const Grid& grid = grids[p];
    const Kernel& kp = kernel[p];
#pragma omp parallel
    {
      RowBuffer found;  // this thread's
      RowSorter sorter;
#pragma omp for schedule(dynamic, 64)
      for (Eigen::Index i = first; i < last; ++i) {
        if (!is_wanted(i)) continue;  // left empty
        const int begin = op.L.outerIndexPtr()[i];
        int* col = op.L.innerIndexPtr() + begin;
        double* d2 = op.L.valuePtr() + begin;  // squared distances, turned into weights by finish_row
        const Eigen::Vector3d normal = intrinsic ? Eigen::Vector3d(measures.normals.row(i).transpose()) : Eigen::Vector3d::Zero();
        grid.gather_within(op.positions.row(i).transpose(), kp.cut, found, false, intrinsic ? &normal : nullptr);
        const int count = op.L.outerIndexPtr()[i + 1] - begin;
        if (found.size != static_cast<std::size_t>(count)) {  // the same test as the count: cannot differ
          mismatch = true;  // no throw inside a parallel region: reported after it
          continue;
        }
        sorter.sort(found, col, d2);  // the part's own rows, then shifted to the operator's
        for (int k = 0; k < count; ++k) col[k] += static_cast<int>(first);
        const Eigen::Index diag = std::lower_bound(col, col + count, static_cast<int>(i)) - col;
        digilap::detail::finish_row(op.L, stiffness, i, diag, weight_mu, kp.inv_4t, kp.scale, row_scale[i]);
      }
    }
  }
  if (mismatch)
    throw Error("heat_laplacian (surfaces): a row found another number of neighbours than it counted (internal error)");
  op.M = digilap::detail::diagonal_matrix(op.mass);
  return op;
}

}  // namespace digilap::surface
