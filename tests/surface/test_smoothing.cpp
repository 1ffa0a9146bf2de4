// surface/smoothing.hpp: fairing of a noisy digital sphere through the core's smoothing.
#include "digilap/surface/smoothing.hpp"
#include "support.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <random>

using namespace digilap;
using namespace digilap::surface;
using namespace digilap::surface::test_support;

// Fairing of a digital sphere whose surfel centres carry noise: the 3D positions through the
// same smoothing core as the 2D contours. Roundness (std / mean of the distance to the
// centroid): 0.0234 for the digital staircase, 0.0295 with the noise (uniform, +-0.03 per
// coordinate), 0.0043 after fairing for tau = 5 t (the shortest scales damped like exp(-5)).
// Asserted: below 0.3 of the noisy and of the digital one, the RMS radius kept to 1e-12.
TEST(Surface, SmoothingFairsANoisySphere) {
  const Pipeline p = run(Sphere(), 0.1, true, 0.1);
  SurfaceOperator noisy = p.op;
  std::mt19937 random(7);
  std::uniform_real_distribution<double> noise(-0.03, 0.03);
  for (Eigen::Index k = 0; k < noisy.positions.size(); ++k) noisy.positions.data()[k] += noise(random);
  SurfaceSmoothingOptions o;
  o.tau = 5 * noisy.t;
  const Eigen::MatrixX3d faired = smooth_positions(noisy, o);
  const double before = roundness(noisy.positions, noisy.mass), after = roundness(faired, noisy.mass);
  std::printf("roundness: digital %.4f, noisy %.4f, faired %.4f\n", roundness(p.op.positions, p.op.mass), before, after);
  EXPECT_LT(after, 0.3 * before);
  EXPECT_LT(after, 0.3 * roundness(p.op.positions, p.op.mass));
  auto rms = [&](const Eigen::MatrixX3d& x) {
    const Eigen::RowVector3d c = (noisy.mass.transpose() * x) / noisy.mass.sum();
    return std::sqrt(noisy.mass.dot((x.rowwise() - c).rowwise().squaredNorm()) / noisy.mass.sum());
  };
  EXPECT_NEAR(rms(faired), rms(noisy.positions), 1e-12 * rms(noisy.positions));
  o.preserve_size = false;  // without the rescaling the sphere shrinks, like exp(-2 tau) at most
  EXPECT_LT(rms(smooth_positions(noisy, o)), rms(noisy.positions));
  EXPECT_THROW(smooth_positions(noisy, {0.0}), Error);
}
