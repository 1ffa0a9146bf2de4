#include "coarse_spread.hpp"

#include "surfel_grid.hpp"

#include <cmath>

namespace digilap::surface::detail {

Eigen::MatrixXd spread_smoothly(const Eigen::MatrixXd& values, const Eigen::MatrixX3d& centres, const Eigen::MatrixX3d& centre_normals,
                                const Eigen::MatrixX3d& points, const Eigen::MatrixX3d& point_normals, const std::vector<int>& own,
                                double cell, bool by_side) {
  // Reach and width in cells: 1.5 and 0.5 take about 7 aggregates a point (the Gaussian is
  // 1% at the reach); the sphere and torus at h = 0.025 converged alike with 2 and 2.5 cells
  // or a width of 0.7; the sphere took one iteration more with a width of 1 (docs/benchmarks.md).
  constexpr double kReach = 1.5, kWidth = 0.5, kSameSide = 0.5;  // cosine of 60 degrees
  const Eigen::Index n = points.rows();
  const double reach = kReach * cell, inv_2w2 = 1 / (2 * (kWidth * cell) * (kWidth * cell));
  const Grid grid(centres, reach);
  Eigen::MatrixXd out(n, values.cols());
#pragma omp parallel
  {
    RowBuffer found;
    Eigen::RowVectorXd sum(values.cols());
#pragma omp for schedule(static)
    for (Eigen::Index k = 0; k < n; ++k) {
      grid.gather_within(points.row(k).transpose(), reach, found);
      sum.setZero();
      double weights = 0;
      for (std::size_t q = 0; q < found.size; ++q) {
        const int a = found.col[q];
        if (by_side && centre_normals.row(a).dot(point_normals.row(k)) < kSameSide) continue;
        const double w = std::exp(-found.d2[q] * inv_2w2);
        sum += w * values.row(a);
        weights += w;
      }
      if (weights > 0) out.row(k) = sum / weights;
      else out.row(k) = values.row(own[static_cast<std::size_t>(k)]);
    }
  }
  return out;
}

}  // namespace digilap::surface::detail
