// surface/ball_moments.hpp: the II normals' ball moments from the tabulated rows (BallRows),
// against a brute-force sum over every voxel of the set. Integers: they must be equal, not close.
#include "surface/ball_moments.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

using namespace digilap::surface;
using namespace digilap::surface::detail;

namespace {
// A speckled blob: the voxels of a ball of radius 9 kept with probability 2/3 (fixed
// pseudo-random), so that rows meet it in many runs, with holes and gaps inside the balls.
std::vector<Eigen::Vector3i> speckled_blob() {
  std::vector<Eigen::Vector3i> voxels;
  std::uint64_t state = 12345;
  for (int k = -9; k <= 9; ++k)
    for (int j = -9; j <= 9; ++j)
      for (int i = -9; i <= 9; ++i) {
        state = state * 6364136223846793005ULL + 1442695040888963407ULL;
        if (i * i + j * j + k * k <= 81 && (state >> 33) % 3 != 0) voxels.emplace_back(i + 3, j - 2, k + 5);
      }
  return voxels;
}

// The moments of the voxel centres within rho of (X, Y, Z) / 2, relative to the voxel
// (floor(X / 2), floor(Y / 2), floor(Z / 2)), voxel by voxel.
Moments brute_force(const std::vector<Eigen::Vector3i>& voxels, std::int64_t X, std::int64_t Y, std::int64_t Z, double rho) {
  auto floor_half = [](std::int64_t a) { return a >= 0 ? a / 2 : -((-a + 1) / 2); };
  const std::int64_t base[3] = {floor_half(X), floor_half(Y), floor_half(Z)}, centre[3] = {X, Y, Z};
  Moments mo;
  for (const Eigen::Vector3i& v : voxels) {
    std::int64_t d2 = 0, d[3];
    for (int a = 0; a < 3; ++a) d2 += (2 * v[a] - centre[a]) * (2 * v[a] - centre[a]), d[a] = v[a] - base[a];
    if (static_cast<double>(d2) > 4 * rho * rho) continue;
    ++mo.n;
    for (int a = 0; a < 3; ++a) {
      mo.s[a] += d[a];
      for (int b = a; b < 3; ++b) mo.ss[a][b] += d[a] * d[b];
    }
  }
  return mo;
}

void expect_equal(const Moments& a, const Moments& b, const char* what) {
  EXPECT_EQ(a.n, b.n) << what;
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(a.s[i], b.s[i]) << what << " s[" << i << "]";
    for (int j = i; j < 3; ++j) EXPECT_EQ(a.ss[i][j], b.ss[i][j]) << what << " ss[" << i << "][" << j << "]";
  }
}
}  // namespace

// Every surfel of the blob (all three axes, both signs), radii with squares on the lattice's
// distances (sqrt 5 / 2: 4 rho^2 = 5 exactly) and between them, one wider than the blob.
TEST(BallMoments, TabulatedRowsEqualTheSumOverEveryVoxel) {
  const std::vector<Eigen::Vector3i> voxels = speckled_blob();
  const VoxelSet set = VoxelSet::from_voxels(1.0, voxels);
  const SurfelSet surfels = extract_surfels(set);
  ASSERT_GT(surfels.size(), 1000u);
  for (const double rho : {0.5, 1.0, 1.1180339887498949, 2.5, 3.7, 6.0, 14.2}) {
    const BallRows ball(rho);
    for (std::size_t s = 0; s < surfels.size(); s += 7) {
      const Surfel& f = surfels.surfels[s];
      const auto c = doubled_centre(f);
      const Moments expected = brute_force(voxels, c[0], c[1], c[2], rho);
      expect_equal(ball.moments(set, f), expected, "BallRows");
      EXPECT_EQ(ball.count(set, f), expected.n) << "BallRows::count";
      if (HasFailure()) FAIL() << "rho " << rho << ", surfel " << s << " (axis " << int(f.axis) << ", sign " << int(f.sign) << ")";
    }
  }
}
