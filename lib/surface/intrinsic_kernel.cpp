#include "intrinsic_kernel.hpp"

#include "core/gaussian_kernel.hpp"

#include <algorithm>
#include <cmath>

namespace digilap::surface::detail {

Eigen::VectorXd estimated_gaussian_curvature(const Grid& grid, const Eigen::MatrixX3d& positions, const Eigen::MatrixX3d& normals,
                                             const Eigen::VectorXd& mu, const Kernel& kernel) {
  const Eigen::Index n = positions.rows();
  Eigen::VectorXd mu_in_grid(n);
  for (std::size_t it = 0; it < grid.items.size(); ++it) mu_in_grid[static_cast<Eigen::Index>(it)] = mu[grid.items[it]];
  Eigen::VectorXd curvature(n);
#pragma omp parallel
  {
    RowBuffer found;                         // this thread's: neighbours in grid order, chords
    std::vector<double> rho2, bend, turn;    // per neighbour; rho2 becomes the weight
#pragma omp for schedule(dynamic, 64)
    for (Eigen::Index i = 0; i < n; ++i) {
      const Eigen::Vector3d q = positions.row(i).transpose(), nq = normals.row(i).transpose();
      grid.gather_within(q, kernel.cut, found, true);
      const std::size_t count = found.size;
      if (rho2.size() < count) rho2.resize(count), bend.resize(count), turn.resize(count);
      for (std::size_t k = 0; k < count; ++k) {
        const auto u = static_cast<std::size_t>(found.col[k]);
        const double dx = grid.xs[u] - q.x(), dy = grid.ys[u] - q.y(), dz = grid.zs[u] - q.z();
        const double sx = grid.nxs[u] + nq.x(), sy = grid.nys[u] + nq.y(), sz = grid.nzs[u] + nq.z();
        const double ex = grid.nxs[u] - nq.x(), ey = grid.nys[u] - nq.y(), ez = grid.nzs[u] - nq.z();
        const double s2 = sx * sx + sy * sy + sz * sz, height = dx * sx + dy * sy + dz * sz;
        // Across a wall (normals more than 90 degrees apart) or itself: no weight (mu factor 0).
        const bool counts = s2 > 2 && found.d2[k] > 0;
        rho2[k] = counts ? found.d2[k] - height * height / s2 : 0.0;
        bend[k] = counts ? (dx * ex + dy * ey + dz * ez) * mu_in_grid[static_cast<Eigen::Index>(u)] : 0.0;
        turn[k] = counts ? (ex * ex + ey * ey + ez * ez) * mu_in_grid[static_cast<Eigen::Index>(u)] : 0.0;
        found.d2[k] = counts ? rho2[k] * mu_in_grid[static_cast<Eigen::Index>(u)] : 0.0;  // rho^2 mu_j
      }
      gaussian_weights(rho2.data(), static_cast<Eigen::Index>(count), kernel.inv_4t, 1.0);  // w = exp(-rho^2 / 4t), vectorized
      double weight = 0, bend_sum = 0, turn_sum = 0;  // in the grid's fixed order
      for (std::size_t k = 0; k < count; ++k) {
        weight += rho2[k] * found.d2[k];
        bend_sum += rho2[k] * bend[k];
        turn_sum += rho2[k] * turn[k];
      }
      double k_estimate = 0;
      if (weight > 0) {
        const double mean = bend_sum / weight;
        k_estimate = 2 * mean * mean - turn_sum / weight;
      }
      curvature[i] = k_estimate;
    }
  }
  return curvature;
}

Eigen::VectorXd curvature_factors(const Grid& grid, const Eigen::MatrixX3d& positions, const Eigen::MatrixX3d& normals,
                                  const Eigen::VectorXd& mu, const Kernel& kernel) {
  const double t = kernel.t;
  return estimated_gaussian_curvature(grid, positions, normals, mu, kernel).unaryExpr([t](double k) {
    return 1 + std::clamp((2.0 / 3.0) * t * k, -kMaxCurvatureCorrection, kMaxCurvatureCorrection);
  });
}

}  // namespace digilap::surface::detail
