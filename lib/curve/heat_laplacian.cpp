#include "digilap/curve/heat_laplacian.hpp"
#include "digilap/core/constants.hpp"

#include "digilap/core/error.hpp"
#include "elements.hpp"
#include "core/gaussian_kernel.hpp"
#include "core/huge_pages.hpp"
#include "core/row_assembly.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>

namespace digilap {
inline namespace curve {

using detail::cyclic_distance;
using detail::Elements;
using detail::gather_elements;
using detail::geodesic_window;
using detail::GeodesicWindow;
using detail::allocate;
using detail::finish_row;

namespace {


void check_positive(const char* what, double v) { require_positive(std::string("heat_laplacian: ") + what, v); }

void check_memory(std::size_t nnz, std::size_t rows, double limit, bool stiffness) {
  detail::check_operator_memory("heat_laplacian", nnz, rows, limit, stiffness, "use a coarser h, or a smaller t or k");
}

// Uniform grid of cell size `cut` over the element positions, for the Euclidean neighbours.
struct PointGrid {
  double cell = 1.0;
  Eigen::Vector2d origin;
  Eigen::Index nx = 1, ny = 1;
  std::vector<Eigen::Index> start, items;

  PointGrid(const Eigen::MatrixX2d& p, double cut) {
    const Eigen::Index n = p.rows();
    origin = p.colwise().minCoeff().transpose();
    const Eigen::Vector2d extent = p.colwise().maxCoeff().transpose() - origin;
    cell = cut;
    // At most ~4 n cells: a coarser grid for a tiny cut only costs more distance tests.
    while ((extent.x() / cell + 1) * (extent.y() / cell + 1) > 4.0 * n + 16) cell *= 2;
    nx = static_cast<Eigen::Index>(extent.x() / cell) + 1;
    ny = static_cast<Eigen::Index>(extent.y() / cell) + 1;
    start.assign(static_cast<std::size_t>(nx * ny + 1), 0);
    for (Eigen::Index r = 0; r < n; ++r) ++start[cell_of(p(r, 0), p(r, 1)) + 1];
    std::partial_sum(start.begin(), start.end(), start.begin());
    items.resize(static_cast<std::size_t>(n));
    std::vector<Eigen::Index> fill(start.begin(), start.end() - 1);
    for (Eigen::Index r = 0; r < n; ++r) items[fill[cell_of(p(r, 0), p(r, 1))]++] = r;  // rows ascending per cell
  }
  Eigen::Index cell_x(double x) const { return std::clamp<Eigen::Index>(static_cast<Eigen::Index>((x - origin.x()) / cell), 0, nx - 1); }
  Eigen::Index cell_y(double y) const { return std::clamp<Eigen::Index>(static_cast<Eigen::Index>((y - origin.y()) / cell), 0, ny - 1); }
  Eigen::Index cell_of(double x, double y) const { return cell_y(y) * nx + cell_x(x); }

  // Calls f(j, d2) for every j != i within distance cut of element i.
  template <class F>
  void for_neighbours(const Eigen::MatrixX2d& p, Eigen::Index i, double cut, F&& f) const {
    const double xi = p(i, 0), yi = p(i, 1), cut2 = cut * cut;
    const Eigen::Index cx = cell_x(xi), cy = cell_y(yi);
    for (Eigen::Index y = std::max<Eigen::Index>(0, cy - 1); y <= std::min(ny - 1, cy + 1); ++y)
      for (Eigen::Index x = std::max<Eigen::Index>(0, cx - 1); x <= std::min(nx - 1, cx + 1); ++x) {
        const Eigen::Index c = y * nx + x;
        for (Eigen::Index it = start[c]; it < start[c + 1]; ++it) {
          const Eigen::Index j = items[it];
          if (j == i) continue;
          const double dx = p(j, 0) - xi, dy = p(j, 1) - yi;
          const double d2 = dx * dx + dy * dy;
          if (d2 <= cut2) f(j, d2);
        }
      }
  }
};

}  // namespace

std::pair<std::size_t, std::size_t> ContourOperator::element(Eigen::Index row) const {
  if (row < 0 || row >= rows()) throw Error("ContourOperator::element: row out of range");
  const auto it = std::upper_bound(row_offset.begin(), row_offset.end(), row);
  const auto c = static_cast<std::size_t>(it - row_offset.begin() - 1);
  return {c, static_cast<std::size_t>(row - row_offset[c])};
}

double heat_time(double h, const HeatLaplacianOptions& options, const Measures& measures) {
  return heat_time(h, options, measures.length_scale);
}

namespace {
// Whether each contour's heat time comes from its own length scale.
bool per_contour_times(const HeatLaplacianOptions& options, const Measures& measures, std::size_t contours) {
  return options.per_contour_time && options.distance == DistanceMode::Geodesic && options.t == 0 &&
         options.length_scale == 0 && measures.contour_length_scales.size() == contours;
}
}  // namespace

std::vector<double> contour_heat_times(double h, const HeatLaplacianOptions& options, const Measures& measures,
                                       std::size_t contours) {
  if (!per_contour_times(options, measures, contours)) return std::vector<double>(contours, heat_time(h, options, measures));
  std::vector<double> t(contours);
  for (std::size_t c = 0; c < contours; ++c) t[c] = heat_time(h, options, measures.contour_length_scales[c]);
  return t;
}

namespace {
ContourOperator assemble(const ContourSet& contours, const Measures& measures, const HeatLaplacianOptions& options);

// The contour with the most rows (whose heat time the operator reports as its t).
std::size_t largest_contour(const std::vector<Eigen::Index>& offset) {
  std::size_t best = 0;
  for (std::size_t c = 0; c + 1 < offset.size(); ++c)
    if (offset[c + 1] - offset[c] > offset[best + 1] - offset[best]) best = c;
  return best;
}

// 2 L_{t/2} - L_t: the pattern of L_{t/2} (cut k sqrt(t/2)) is inside that of L_t.
ContourOperator richardson(const ContourSet& contours, const Measures& measures, const HeatLaplacianOptions& options) {
  HeatLaplacianOptions plain = options;  // one t for all contours
  plain.t = heat_time(contours.h, options, measures);
  ContourOperator op = assemble(contours, measures, plain);
  plain.t *= 0.5;
  const ContourOperator half = assemble(contours, measures, plain);
  op.L = 2.0 * half.L - op.L;
  if (options.stiffness) op.A = 2.0 * half.A - op.A;
  op.length_scale = options.t != 0 ? 0.0 : (options.length_scale != 0 ? options.length_scale : measures.length_scale);
  return op;
}
}  // namespace

ContourOperator heat_laplacian(const ContourSet& contours, const Measures& measures,
                               const HeatLaplacianOptions& options) {
  // One named result per function: Eigen 3.4's SparseMatrix has no move constructor, so a
  // returned operator must be elided, never moved (a copy of L and A cost 15% of the time).
  return options.richardson ? richardson(contours, measures, options) : assemble(contours, measures, options);
}

namespace {
ContourOperator assemble(const ContourSet& contours, const Measures& measures, const HeatLaplacianOptions& options) {
  check_positive("k", options.k);
  const Elements e = gather_elements(contours, measures, options.placement);
  const Eigen::Index n = e.offset.back();
  const std::vector<double> contour_t = contour_heat_times(contours.h, options, measures, e.offset.size() - 1);
  // One t where the contours interact (Euclidean), possibly one per contour otherwise.
  const double t = contour_t.empty() ? heat_time(contours.h, options, measures) : contour_t[largest_contour(e.offset)];
  const double cut = options.k * std::sqrt(t);
  const double inv_4t = 1.0 / (4.0 * t), scale = 1.0 / (t * std::sqrt(4.0 * kPi * t));

  ContourOperator op;
  op.placement = options.placement;
  op.t = t;
  op.part_t = contour_t;
  op.length_scale = options.t != 0 ? 0.0
                    : options.length_scale != 0 ? options.length_scale
                    : per_contour_times(options, measures, contour_t.size()) && !contour_t.empty()
                        ? measures.contour_length_scales[largest_contour(e.offset)]
                        : measures.length_scale;
  op.cut = cut;
  op.positions = e.positions;
  op.mass = e.mu;
  op.arclength = e.s;
  op.row_offset = e.offset;
  op.contour_length = e.length;

  std::vector<Eigen::Index> row_nnz(static_cast<std::size_t>(n));
  SparseMatrix* stiffness = options.stiffness ? &op.A : nullptr;
  if (options.distance == DistanceMode::Geodesic) {
    // Pass 1: each row's cyclic window, hence the exact pattern, before any allocation.
    std::vector<GeodesicWindow> window(static_cast<std::size_t>(n));
    for (std::size_t c = 0; c + 1 < e.offset.size(); ++c) {
      const Eigen::Index off = e.offset[c], len = e.offset[c + 1] - off;
      const double P = e.length[c], cut_c = options.k * std::sqrt(contour_t[c]);
#pragma omp parallel for schedule(static)
      for (Eigen::Index i = 0; i < len; ++i) {
        window[off + i] = geodesic_window(e.s.data() + off, len, i, P, cut_c);
        row_nnz[off + i] = window[off + i].back + window[off + i].fwd + 1;
      }
    }
    check_memory(static_cast<std::size_t>(std::accumulate(row_nnz.begin(), row_nnz.end(), Eigen::Index(0))),
                 static_cast<std::size_t>(n), options.memory_limit_bytes, options.stiffness);
    allocate(op.L, n, row_nnz);
    if (options.stiffness) allocate(op.A, n, row_nnz);
    // Pass 2: fill the rows in parallel; columns of a cyclic window, rotated to be ascending.
    for (std::size_t c = 0; c + 1 < e.offset.size(); ++c) {
      const Eigen::Index off = e.offset[c], len = e.offset[c + 1] - off;
      const double P = e.length[c], t_c = contour_t[c];
      const double inv_4t_c = 1.0 / (4.0 * t_c), scale_c = 1.0 / (t_c * std::sqrt(4.0 * kPi * t_c));
      const double* s = e.s.data() + off;
#pragma omp parallel for schedule(dynamic, 64)
      for (Eigen::Index i = 0; i < len; ++i) {
        const GeodesicWindow w = window[off + i];
        const int begin = op.L.outerIndexPtr()[off + i];
        int* col = op.L.innerIndexPtr() + begin;
        double* d2 = op.L.valuePtr() + begin;
        // The cyclic window [i - back, i + fwd] as at most two ascending runs of local indices:
        // [0, i + fwd - len] after a wrap, then [i - back, ...] or the unwrapped window.
        const Eigen::Index lo = i - w.back, hi = i + w.fwd;  // may leave [0, len)
        Eigen::Index k = 0, diag = 0;
        auto emit = [&](Eigen::Index a, Eigen::Index b) {  // local indices a..b inclusive
          for (Eigen::Index j = a; j <= b; ++j, ++k) {
            const double d = cyclic_distance(s[i], s[j], P);
            col[k] = static_cast<int>(off + j);
            d2[k] = d * d;
            if (j == i) diag = k, d2[k] = 0.0;
          }
        };
        if (hi >= len) emit(0, hi - len);
        emit(std::max<Eigen::Index>(lo, 0), std::min(hi, len - 1));
        if (lo < 0) emit(lo + len, len - 1);
        finish_row(op.L, stiffness, off + i, diag, e.mu, inv_4t_c, scale_c);
      }
    }
  } else {
    const PointGrid grid(e.positions, cut);
#pragma omp parallel for schedule(dynamic, 256)
    for (Eigen::Index i = 0; i < n; ++i) {
      Eigen::Index count = 1;
      grid.for_neighbours(e.positions, i, cut, [&](Eigen::Index, double) { ++count; });
      row_nnz[i] = count;
    }
    check_memory(static_cast<std::size_t>(std::accumulate(row_nnz.begin(), row_nnz.end(), Eigen::Index(0))),
                 static_cast<std::size_t>(n), options.memory_limit_bytes, options.stiffness);
    allocate(op.L, n, row_nnz);
    if (options.stiffness) allocate(op.A, n, row_nnz);
#pragma omp parallel
    {
      std::vector<unsigned char> mark;  // per thread: candidates over a row's column range
#pragma omp for schedule(dynamic, 256)
      for (Eigen::Index i = 0; i < n; ++i) {
        // Gather the columns straight into L's index slots, then put them in ascending order.
        // Rows of a contour see mostly one window of consecutive elements, so marking the
        // columns over their range and sweeping it beats a comparison sort; rows whose
        // neighbours are scattered (the contour comes back, several contours) fall back to it.
        const int begin = op.L.outerIndexPtr()[i], count = op.L.outerIndexPtr()[i + 1] - begin;
        int* col = op.L.innerIndexPtr() + begin;
        double* d2 = op.L.valuePtr() + begin;
        int k = 0, lo = static_cast<int>(i), hi = static_cast<int>(i);
        col[k++] = static_cast<int>(i);
        grid.for_neighbours(e.positions, i, cut, [&](Eigen::Index j, double) {
          col[k++] = static_cast<int>(j);
          lo = std::min(lo, static_cast<int>(j));
          hi = std::max(hi, static_cast<int>(j));
        });
        if (hi - lo < 4 * count) {
          mark.assign(static_cast<std::size_t>(hi - lo + 1), 0);
          for (k = 0; k < count; ++k) mark[col[k] - lo] = 1;
          k = 0;
          for (int c = lo; c <= hi; ++c)
            if (mark[c - lo]) col[k++] = c;
        } else {
          std::sort(col, col + count);
        }
        // Squared distances in column order, by the same expression as the search: same bits.
        const double xi = e.positions(i, 0), yi = e.positions(i, 1);
        Eigen::Index diag = 0;
        for (k = 0; k < count; ++k) {
          const double dx = e.positions(col[k], 0) - xi, dy = e.positions(col[k], 1) - yi;
          d2[k] = dx * dx + dy * dy;
          if (col[k] == i) diag = k;
        }
        finish_row(op.L, stiffness, i, diag, e.mu, inv_4t, scale);
      }
    }
  }
  op.M = detail::diagonal_matrix(e.mu);
  return op;
}
}  // namespace

}  // namespace curve
}  // namespace digilap
