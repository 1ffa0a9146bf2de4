// surface/measures.hpp: the surfel areas mu = h^2 max(0, <n, n_e>) (SPEC §7), their sum against
// the surface's area, the clamped count, and the refusals.
#include "digilap/surface/measures.hpp"
#include "error_of.hpp"
#include "support.hpp"

#include <gtest/gtest.h>

#include <cstdio>

using namespace digilap;
using namespace digilap::surface;
using namespace digilap::surface::test_support;

// Per surfel, exactly the formula (n_e has one non-zero coordinate, +-1: the dot product is
// that coordinate of n, exactly); the normals' length scale and radius carried along.
TEST(SurfaceMeasures, EachSurfelHasHSquaredTimesTheCosine) {
  const double h = 0.1;
  const VoxelSet v = digitize(*posed(make_surface("torus")), h);
  const SurfelSet f = extract_surfels(v);
  const SurfelNormals n = ii_normals(v, f, {1.0, 1.0});
  const SurfelMeasures m = measures(f, n);
  ASSERT_EQ(m.mu.size(), static_cast<Eigen::Index>(f.size()));
  std::size_t clamped = 0;
  for (std::size_t s = 0; s < f.size(); ++s) {
    const double cosine = n.normals(static_cast<Eigen::Index>(s), f.surfels[s].axis) * f.surfels[s].sign;
    clamped += cosine <= 0;
    EXPECT_EQ(m.mu[static_cast<Eigen::Index>(s)], h * h * std::max(0.0, cosine)) << "surfel " << s;
  }
  EXPECT_EQ(m.clamped, clamped);
  EXPECT_EQ(m.length_scale, n.length_scale);
  EXPECT_EQ(m.normal_radius, n.radius);
}

// With exact normals, sum mu converges to the area: the unit sphere (4 pi) and the torus
// (4 pi^2 R r). Measured: 3.4e-4 -> 2.9e-4 (sphere) and 1.6e-3 -> 9.2e-4 (torus) from h = 0.1
// to 0.05. Asserted: below 0.3% at h = 0.05, and falling.
TEST(SurfaceMeasures, TotalAreaConvergesToTheSurfaceArea) {
  for (const char* name : {"sphere", "torus"}) {
    const auto s = posed(make_surface(name));
    auto error = [&](double h) {
      const SurfelSet f = extract_surfels(digitize(*s, h));
      return std::abs(measures(f, exact_normals(*s, f, 1.0)).total_area() - s->area()) / s->area();
    };
    const double coarse = error(0.1), fine = error(0.05);
    std::printf("%s: area error %.2e (h = 0.1) -> %.2e (h = 0.05)\n", name, coarse, fine);
    EXPECT_LT(fine, 0.003) << name;
    EXPECT_LT(fine, coarse) << name;
  }
}

// A normal against its surfel's outward direction: mu clamped to 0 and counted.
TEST(SurfaceMeasures, FlippedNormalsAreClampedAndCounted) {
  const SurfelSet f = extract_surfels(digitize(Sphere(), 0.2));
  SurfelNormals n = exact_normals(Sphere(), f, 1.0);
  n.normals.row(0) *= -1;
  n.normals.row(1) = Eigen::RowVector3d::Zero();
  n.normals(1, (f.surfels[1].axis + 1) % 3) = 1;  // tangent to the surfel: cosine 0
  const SurfelMeasures m = measures(f, n);
  EXPECT_EQ(m.clamped, 2u);
  EXPECT_EQ(m.mu[0], 0.0);
  EXPECT_EQ(m.mu[1], 0.0);
  EXPECT_GT(m.mu[2], 0.0);
}

TEST(SurfaceMeasures, NormalsOfAnotherSetAreRefused) {
  const SurfelSet f = extract_surfels(digitize(Sphere(), 0.2)), g = extract_surfels(digitize(Sphere(), 0.25));
  EXPECT_THROW(measures(f, exact_normals(Sphere(), g, 1.0)), Error);
}
