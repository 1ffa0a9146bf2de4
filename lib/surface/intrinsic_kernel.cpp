#include "intrinsic_kernel.hpp"

#include <algorithm>
#include <cmath>

namespace digilap::surface::detail {

Eigen::VectorXd estimated_gaussian_curvature(const Grid& grid, const Eigen::MatrixX3d& positions, const Eigen::MatrixX3d& normals,
                                             const Eigen::VectorXd& mu, const Kernel& kernel) {
  const Eigen::Index n = positions.rows();
  Eigen::VectorXd mu_in_grid(n);
  for (std::size_t it = 0; it < grid.items.size(); ++it) mu_in_grid[static_cast<Eigen::Index>(it)] = mu[grid.items[it]];
  Eigen::VectorXd curvature(n);
  const double cut2 = kernel.cut * kernel.cut;
#pragma omp parallel for schedule(dynamic, 64)
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector3d q = positions.row(i).transpose(), nq = normals.row(i).transpose();
    double weight = 0, bend = 0, turn = 0;  // sums over the neighbours, in the grid's fixed order
    grid.for_candidates(q, kernel.cut, [&](Eigen::Index first, Eigen::Index last) {
      for (Eigen::Index it = first; it < last; ++it) {
        const auto u = static_cast<std::size_t>(it);
        const double dx = grid.xs[u] - q.x(), dy = grid.ys[u] - q.y(), dz = grid.zs[u] - q.z();
        const double chord2 = dx * dx + dy * dy + dz * dz;
        const double sx = grid.nxs[u] + nq.x(), sy = grid.nys[u] + nq.y(), sz = grid.nzs[u] + nq.z();
        const double ex = grid.nxs[u] - nq.x(), ey = grid.nys[u] - nq.y(), ez = grid.nzs[u] - nq.z();
        const double s2 = sx * sx + sy * sy + sz * sz;
        if (chord2 > cut2 || !(s2 > 2) || chord2 == 0) continue;  // outside, across a wall, or itself
        const double height = dx * sx + dy * sy + dz * sz;
        const double rho2 = chord2 - height * height / s2;
        const double w = std::exp(-rho2 * kernel.inv_4t) * mu_in_grid[it];
        weight += w * rho2;
        bend += w * (dx * ex + dy * ey + dz * ez);
        turn += w * (ex * ex + ey * ey + ez * ez);
      }
    });
    double k = 0;
    if (weight > 0) {
      const double mean = bend / weight;
      k = 2 * mean * mean - turn / weight;
    }
    curvature[i] = k;
  }
  return curvature;
}

Eigen::VectorXd curvature_factors(const Eigen::VectorXd& gaussian_curvature, double t) {
  return gaussian_curvature.unaryExpr([t](double k) {
    return 1 + std::clamp((2.0 / 3.0) * t * k, -kMaxCurvatureCorrection, kMaxCurvatureCorrection);
  });
}

}  // namespace digilap::surface::detail
