#include "intrinsic_kernel.hpp"

#include "core/gaussian_kernel.hpp"
#include "core/lanes.hpp"
#include "surfel_tiles.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

namespace digilap::surface::detail {

namespace {
using digilap::detail::Lanes8;

// One row's terms over a tile's candidates (surfel_tiles.hpp), for the neighbours that count
// (within the cut, not at the row's own place, normals within 90 degrees; 0 elsewhere): the
// tangent chord rho^2 (into rho2, which becomes the weight), rho^2 mu_j, <d, e> mu_j and
// |e|^2 mu_j. A loop without branches, so that it vectorizes (a row at a time with its own
// neighbour search, this pass was a tenth of a sphere's spectrum at h = 0.0125). The reciprocal
// (surfel_grid.hpp) takes |s|^2 where the neighbour counts and 1 elsewhere.
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void curvature_terms(
    const TileBuffer& b, std::size_t count, const double* q, const double* nq, double cut2, double* __restrict rho2,
    double* __restrict rho2_mu, double* __restrict bend, double* __restrict turn) {
  const double* __restrict x = b.x.data();
  const double* __restrict y = b.y.data();
  const double* __restrict z = b.z.data();
  const double* __restrict nx = b.nx.data();
  const double* __restrict ny = b.ny.data();
  const double* __restrict nz = b.nz.data();
  const double* __restrict mu = b.value.data();
  for (std::size_t k = 0; k < count; ++k) {
    const double dx = x[k] - q[0], dy = y[k] - q[1], dz = z[k] - q[2];
    const double sx = nx[k] + nq[0], sy = ny[k] + nq[1], sz = nz[k] + nq[2];
    const double ex = nx[k] - nq[0], ey = ny[k] - nq[1], ez = nz[k] - nq[2];
    const double chord2 = dx * dx + dy * dy + dz * dz;
    const double s2 = sx * sx + sy * sy + sz * sz, height = dx * sx + dy * sy + dz * sz;
    const bool counts = s2 > 2 && chord2 > 0 && chord2 <= cut2;
    const double r2 = counts ? chord2 - height * height * reciprocal_of_normals_sum(counts ? s2 : 1.0) : 0.0;
    rho2[k] = r2;
    rho2_mu[k] = r2 * mu[k];
    bend[k] = counts ? (dx * ex + dy * ey + dz * ez) * mu[k] : 0.0;
    turn[k] = counts ? (ex * ex + ey * ey + ez * ez) * mu[k] : 0.0;
  }
}

// sum_k w_k a_k for a = rho2_mu, bend, turn: 8 partial sums each, added in a fixed order (the
// same bits whatever the thread).
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void weighted_sums(
    const double* __restrict w, const double* __restrict rho2_mu, const double* __restrict bend, const double* __restrict turn,
    std::size_t count, double* sums) {
  Lanes8 partial[3] = {};
  std::size_t k = 0;
  for (; k + 8 <= count; k += 8) {
    Lanes8 wk, a, c, d;
    std::memcpy(&wk, w + k, sizeof(wk)), std::memcpy(&a, rho2_mu + k, sizeof(a));
    std::memcpy(&c, bend + k, sizeof(c)), std::memcpy(&d, turn + k, sizeof(d));
    partial[0] += wk * a, partial[1] += wk * c, partial[2] += wk * d;
  }
  for (int s = 0; s < 3; ++s) {
    sums[s] = 0;
    for (int l = 0; l < 8; ++l) sums[s] += partial[s][l];
  }
  for (; k < count; ++k) sums[0] += w[k] * rho2_mu[k], sums[1] += w[k] * bend[k], sums[2] += w[k] * turn[k];
}
}  // namespace

Eigen::VectorXd estimated_gaussian_curvature(const Grid& grid, const Eigen::MatrixX3d& positions, const Eigen::MatrixX3d& normals,
                                             const Eigen::VectorXd& mu, const Kernel& kernel) {
  const Eigen::Index n = positions.rows();
  if (static_cast<Eigen::Index>(grid.items.size()) != n || normals.rows() != n || mu.size() != n || grid.nxs.empty())
    throw Error("estimated_gaussian_curvature: the grid, positions, normals and measures disagree (internal error)");
  Eigen::VectorXd mu_in_grid(n);
  for (std::size_t it = 0; it < grid.items.size(); ++it) mu_in_grid[static_cast<Eigen::Index>(it)] = mu[grid.items[it]];
  Eigen::VectorXd curvature(n);
  const Tiles tiles(grid);
  const double cut2 = kernel.cut * kernel.cut;
#pragma omp parallel
  {
    TileBuffer buffer;  // this thread's: the candidates, then per row its weights and terms
    std::vector<double> rho2_mu, bend;
#pragma omp for schedule(dynamic, 16)
    for (Eigen::Index tile = 0; tile < tiles.size(); ++tile) {
      const Eigen::Index first = tiles.first(tile);
      const std::size_t count = gather_tile_candidates(grid, first, tiles.rows(tile), kernel.cut, mu_in_grid.data(), buffer);
      if (rho2_mu.size() < count) rho2_mu.resize(2 * count), bend.resize(2 * count);
      for (int r = 0; r < tiles.rows(tile); ++r) {
        const auto at = static_cast<std::size_t>(first + r);
        const double q[3] = {grid.xs[at], grid.ys[at], grid.zs[at]}, nq[3] = {grid.nxs[at], grid.nys[at], grid.nzs[at]};
        double* w = buffer.d2[r].data();
        double* turn = buffer.chord2[r].data();
        curvature_terms(buffer, count, q, nq, cut2, w, rho2_mu.data(), bend.data(), turn);
        gaussian_weights_wide(w, static_cast<Eigen::Index>(count), kernel.inv_4t, 1.0);  // w = exp(-rho^2 / 4t)
        double sums[3];  // weight, bend, turn, in the candidates' fixed order
        weighted_sums(w, rho2_mu.data(), bend.data(), turn, count, sums);
        double k_estimate = 0;
        if (sums[0] > 0) {
          const double mean = sums[1] / sums[0];
          k_estimate = 2 * mean * mean - sums[2] / sums[0];
        }
        curvature[grid.items[at]] = k_estimate;
      }
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
