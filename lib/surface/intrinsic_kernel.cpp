#include "intrinsic_kernel.hpp"

#include "core/gaussian_kernel.hpp"
#include "core/lanes.hpp"
#include "surfel_tiles.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

namespace digilap::surface::detail {

namespace {
using digilap::detail::Lanes8;

// The three sums a row's K is made of (intrinsic_kernel.hpp): sum w rho^2 mu_j, sum w <d, e>
// mu_j, sum w |e|^2 mu_j.
constexpr int kSums = 3;

// One row's tangent chords rho^2 over its tile's candidates (surfel_tiles.hpp) for the pairs that
// count (after the row in the grid's order, `self`, and within the cut; normals within 90
// degrees): into rho2 (0 elsewhere) and into w (+infinity elsewhere, which
// gaussian_weights_wide turns into a weight of exactly 0). rho^2, like the pair's other terms
// (tile_shares), is the same for (i, j) and (j, i) bit for bit (d and e change sign, s does
// not), so each pair is computed once. A loop without branches, so that it vectorizes; rho^2 is
// the intrinsic distance's own (tangent_chord, surfel_grid.hpp), bit for bit.
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void upper_tangent_chords(
    const TileBuffer& b, std::size_t count, const double* q, const double* nq, double cut2, int self, double* __restrict w,
    double* __restrict rho2) {
  constexpr double kOut = std::numeric_limits<double>::infinity();
  const double *__restrict x = b.x.data(), *__restrict y = b.y.data(), *__restrict z = b.z.data();
  const double *__restrict nx = b.nx.data(), *__restrict ny = b.ny.data(), *__restrict nz = b.nz.data();
  const int* __restrict col = b.col.data();
  for (std::size_t k = 0; k < count; ++k) {
    const TangentChord t = tangent_chord(x, y, z, nx, ny, nz, k, q, nq);
    const bool counts = t.shared && t.chord2 > 0 && t.chord2 <= cut2 && col[k] > self;
    w[k] = counts ? t.rho2 : kOut;
    rho2[k] = counts ? t.rho2 : 0.0;
  }
}

// The tile's pairs' three weighted terms, w rho^2, w <d, e> and w |e|^2 (0 where w is), for its
// `rows` rows (centre q[r], normal nq[r], measure mu_rows[r]; weights w[r] and chords rho2[r]
// over the candidates): into the rows' own sums, sums[r][a] = sum_k term mu_k, and into what
// each candidate receives, received[a][k] = sum_r term mu_rows[r]. Candidates 8 at a time, the
// rows inside, so that each candidate's values are loaded once for the tile; every sum runs in a
// fixed order (8 partial sums a row, added lane by lane, then the tail).
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void tile_shares(
    const TileBuffer& b, std::size_t count, int rows, const double (*q)[3], const double (*nq)[3], const double* mu_rows,
    const double* const* w, const double* const* rho2, double (*sums)[kSums], double* const* received) {
  const double *__restrict x = b.x.data(), *__restrict y = b.y.data(), *__restrict z = b.z.data();
  const double *__restrict nx = b.nx.data(), *__restrict ny = b.ny.data(), *__restrict nz = b.nz.data();
  const double* __restrict mu = b.value.data();
  Lanes8 partial[kTileRows][kSums] = {};
  std::size_t k = 0;
  for (; k + 8 <= count; k += 8) {
    Lanes8 xk, yk, zk, nxk, nyk, nzk, muk;
    std::memcpy(&xk, x + k, sizeof(xk)), std::memcpy(&yk, y + k, sizeof(yk)), std::memcpy(&zk, z + k, sizeof(zk));
    std::memcpy(&nxk, nx + k, sizeof(nxk)), std::memcpy(&nyk, ny + k, sizeof(nyk)), std::memcpy(&nzk, nz + k, sizeof(nzk));
    std::memcpy(&muk, mu + k, sizeof(muk));
    Lanes8 in[kSums] = {};
    for (int r = 0; r < rows; ++r) {
      const Lanes8 dx = xk - q[r][0], dy = yk - q[r][1], dz = zk - q[r][2];
      const Lanes8 ex = nxk - nq[r][0], ey = nyk - nq[r][1], ez = nzk - nq[r][2];
      Lanes8 wk, chord;
      std::memcpy(&wk, w[r] + k, sizeof(wk)), std::memcpy(&chord, rho2[r] + k, sizeof(chord));
      const Lanes8 term[kSums] = {wk * chord, wk * (dx * ex + dy * ey + dz * ez), wk * (ex * ex + ey * ey + ez * ez)};
      for (int a = 0; a < kSums; ++a) partial[r][a] += term[a] * muk, in[a] += term[a] * mu_rows[r];
    }
    for (int a = 0; a < kSums; ++a) std::memcpy(received[a] + k, &in[a], sizeof(in[a]));
  }
  for (int r = 0; r < rows; ++r)
    for (int a = 0; a < kSums; ++a) {
      sums[r][a] = 0;
      for (int l = 0; l < 8; ++l) sums[r][a] += partial[r][a][l];
    }
  for (; k < count; ++k) {
    double in[kSums] = {};
    for (int r = 0; r < rows; ++r) {
      const double dx = x[k] - q[r][0], dy = y[k] - q[r][1], dz = z[k] - q[r][2];
      const double ex = nx[k] - nq[r][0], ey = ny[k] - nq[r][1], ez = nz[k] - nq[r][2];
      const double wk = w[r][k];
      const double term[kSums] = {wk * rho2[r][k], wk * (dx * ex + dy * ey + dz * ez), wk * (ex * ex + ey * ey + ez * ez)};
      for (int a = 0; a < kSums; ++a) sums[r][a] += term[a] * mu[k], in[a] += term[a] * mu_rows[r];
    }
    for (int a = 0; a < kSums; ++a) received[a][k] = in[a];
  }
}
}  // namespace

// Each pair once, as the matrix-free products take them: from the tile of its first item in the
// grid's order, its terms going into that row's sums and into the other row's (a sphere at
// h = 0.0125: every pair from both rows was a tenth of the operator's set-up). The tiles run layer by layer
// (TileLayers): a row's sums from each layer distance in their own block, added in that order,
// the same bits whatever the threads.
Eigen::VectorXd estimated_gaussian_curvature(const Grid& grid, const Eigen::MatrixX3d& positions, const Eigen::MatrixX3d& normals,
                                             const Eigen::VectorXd& mu, const Kernel& kernel) {
  const Eigen::Index n = positions.rows();
  if (static_cast<Eigen::Index>(grid.items.size()) != n || normals.rows() != n || mu.size() != n || grid.nxs.empty())
    throw Error("estimated_gaussian_curvature: the grid, positions, normals and measures disagree (internal error)");
  Eigen::VectorXd mu_in_grid(n);
  for (std::size_t it = 0; it < grid.items.size(); ++it) mu_in_grid[static_cast<Eigen::Index>(it)] = mu[grid.items[it]];
  const Tiles tiles(grid);
  const TileLayers layers(grid, tiles);
  const int reach = grid.reach;
  // image[d].col(it): item it's three sums from the tiles d layers before its own.
  std::vector<Eigen::MatrixXd> image(static_cast<std::size_t>(reach + 1), Eigen::MatrixXd::Zero(kSums, n));
  const double cut2 = kernel.cut * kernel.cut;
#pragma omp parallel
  {
    TileBuffer buffer;  // this thread's: the candidates, then per row its weights and terms
    std::vector<double> storage;
    std::vector<Eigen::Index> end(static_cast<std::size_t>(reach + 1));
#pragma omp for schedule(dynamic, 1)
    for (Eigen::Index layer = 0; layer < layers.layers(); ++layer)
      for (Eigen::Index tile = layers.tile[static_cast<std::size_t>(layer)]; tile < layers.tile[static_cast<std::size_t>(layer + 1)]; ++tile) {
        const Eigen::Index first = tiles.first(tile);
        const int rows = tiles.rows(tile);
        const std::size_t count = gather_tile_candidates(grid, first, rows, kernel.cut, mu_in_grid.data(), buffer, first);
        // Per row its weights (the buffer's d2) and tangent chords (the buffer's chord2), then the pairs' terms.
        if (storage.size() < kSums * count) storage.resize(2 * kSums * count);
        double* w[kTileRows];
        double* rho2[kTileRows];
        double* received[kSums];
        for (int a = 0; a < kSums; ++a) received[a] = storage.data() + a * count;
        double q[kTileRows][3], nq[kTileRows][3], mu_rows[kTileRows];
        for (int r = 0; r < rows; ++r) {
          const auto at = static_cast<std::size_t>(first + r);
          q[r][0] = grid.xs[at], q[r][1] = grid.ys[at], q[r][2] = grid.zs[at];
          nq[r][0] = grid.nxs[at], nq[r][1] = grid.nys[at], nq[r][2] = grid.nzs[at];
          w[r] = buffer.d2[r].data(), rho2[r] = buffer.chord2[r].data();
          upper_tangent_chords(buffer, count, q[r], nq[r], cut2, static_cast<int>(at), w[r], rho2[r]);
          gaussian_weights_wide(w[r], static_cast<Eigen::Index>(count), kernel.inv_4t, 1.0);  // w = exp(-rho^2 / 4t)
          mu_rows[r] = mu_in_grid[static_cast<Eigen::Index>(at)];
        }
        double sums[kTileRows][kSums];
        tile_shares(buffer, count, rows, q, nq, mu_rows, w, rho2, sums, received);
        // The candidates' shares by layer distance (the tile's own rows among them), then the rows' own sums.
        const int* col = buffer.col.data();
        const int segments = layers.segment_ends(layer, reach, col, count, end.data());
        std::size_t k = 0;
        for (int d = 0; d < segments; ++d) {
          double* target = image[static_cast<std::size_t>(d)].data();
          for (; k < static_cast<std::size_t>(end[static_cast<std::size_t>(d)]); ++k)
            for (int a = 0; a < kSums; ++a) target[kSums * static_cast<std::ptrdiff_t>(col[k]) + a] += received[a][k];
        }
        for (int r = 0; r < rows; ++r)
          for (int a = 0; a < kSums; ++a) image[0](a, first + r) += sums[r][a];
      }
  }
  Eigen::VectorXd curvature(n);
#pragma omp parallel for schedule(static)
  for (Eigen::Index it = 0; it < n; ++it) {
    double sums[kSums];
    for (int a = 0; a < kSums; ++a) {
      sums[a] = 0;
      for (const Eigen::MatrixXd& m : image) sums[a] += m(a, it);
    }
    double k_estimate = 0;  // weight, bend, turn
    if (sums[0] > 0) {
      const double mean = sums[1] / sums[0];
      k_estimate = 2 * mean * mean - sums[2] / sums[0];
    }
    curvature[grid.items[static_cast<std::size_t>(it)]] = k_estimate;
  }
  return curvature;
}

Eigen::VectorXd curvature_factors(const Grid& grid, const Eigen::MatrixX3d& positions, const Eigen::MatrixX3d& normals,
                                  const Eigen::VectorXd& mu, const Kernel& kernel) {
  const double t = kernel.t;
  return estimated_gaussian_curvature(grid, positions, normals, mu, kernel).unaryExpr([t](double k) {
    return 1 + std::clamp(0.5 * t * k, -kMaxCurvatureCorrection, kMaxCurvatureCorrection);
  });
}

}  // namespace digilap::surface::detail
