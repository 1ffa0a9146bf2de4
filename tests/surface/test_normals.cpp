// surface/normals.hpp: Integral Invariant normals against the exact normals of the reference
// surfaces (SPEC §7), their convergence as h falls, and the refusals.
#include "digilap/surface/normals.hpp"
#include "error_of.hpp"
#include "support.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

using namespace digilap;
using namespace digilap::surface;
using namespace digilap::surface::test_support;

namespace {
// Mean and largest angle (radians) between the II normals (k_R = 1, l = 1: R = h^(1/3)) and
// the exact ones at the surfel centres' closest points.
std::pair<double, double> angle_errors(const Surface& s, double h) {
  const VoxelSet v = digitize(s, h);
  const SurfelSet f = extract_surfels(v);
  const SurfelNormals ii = ii_normals(v, f, {1.0, 1.0}), exact = exact_normals(s, f, 1.0);
  double sum = 0, worst = 0;
  for (Eigen::Index i = 0; i < ii.normals.rows(); ++i) {
    const double a = std::acos(std::min(1.0, ii.normals.row(i).dot(exact.normals.row(i))));
    sum += a, worst = std::max(worst, a);
  }
  return {sum / static_cast<double>(ii.normals.rows()), worst};
}
}  // namespace

// The II normal's error is O(h^(2/3)) with R = h^(1/3) (SPEC §7): from h = 0.1 to 0.05 the mean
// angle falls by 2^(2/3) = 1.59 in theory. Measured (posed off the lattice; printed below): the
// sphere 1.14 -> 0.46 degrees (worst 3.7 -> 1.4), the torus 3.35 -> 1.65 (worst 5.9 at h = 0.05,
// on its inner rim; the plain estimator of SPEC §7: 1.12 -> 0.65 and 3.33 -> 1.74). Asserted: a fall by at least 1.3, a mean below 2 degrees at h = 0.05, no normal more
// than 10 degrees off (none flips).
TEST(SurfaceNormals, IntegralInvariantNormalsConvergeToTheExactOnes) {
  for (const char* name : {"sphere", "torus"}) {
    const auto s = posed(make_surface(name));
    const auto [coarse_mean, coarse_worst] = angle_errors(*s, 0.1);
    const auto [fine_mean, fine_worst] = angle_errors(*s, 0.05);
    std::printf("%s: mean angle %.3f -> %.3f deg, worst %.2f -> %.2f deg\n", name, coarse_mean * 180 / kPi, fine_mean * 180 / kPi,
                coarse_worst * 180 / kPi, fine_worst * 180 / kPi);
    EXPECT_GT(coarse_mean / fine_mean, 1.3) << name;
    EXPECT_LT(fine_mean, 2 * kPi / 180) << name;
    EXPECT_LT(fine_worst, 10 * kPi / 180) << name;
  }
}

// The digital ball's anisotropy: its covariance differs along the surfel's axis and across it,
// by an amount whose sign changes with rho, and the plain estimator (SPEC §7) tilts the normals
// accordingly. The area sum(mu) of the unit sphere (exact 4 pi; exact normals give +0.1% at this
// h) against rho = 3.25 ... 8 voxels at h = 0.03: the plain estimator's swings by +-3%
// (measured: -1.35% ... +2.92%), the default's stays within +-0.25% (printed). Asserted: the
// default within 0.6% at every rho, the plain one beyond 1.5% at some rho (what was fixed), and
// the default's worst at most a fifth of the plain's.
TEST(SurfaceNormals, TheDigitalBallsAnisotropyDoesNotTiltTheNormals) {
  const auto sphere = posed(make_surface("sphere"));
  const double h = 0.03;
  const VoxelSet v = digitize(*sphere, h);
  const SurfelSet f = extract_surfels(v);
  double worst_default = 0, worst_plain = 0;
  for (double rho = 3.25; rho <= 8.0; rho += 0.25) {
    SurfaceNormalOptions o;
    o.k_R = rho * h / std::cbrt(h), o.length_scale = 1.0;  // R = rho h
    const double fixed = measures(f, ii_normals(v, f, o)).total_area() / (4 * kPi) - 1;
    o.remove_ball_anisotropy = false;
    const double plain = measures(f, ii_normals(v, f, o)).total_area() / (4 * kPi) - 1;
    std::printf("rho %.2f: area error %+.2f%% (plain %+.2f%%)\n", rho, 100 * fixed, 100 * plain);
    EXPECT_LT(std::abs(fixed), 0.006) << "rho = " << rho;
    worst_default = std::max(worst_default, std::abs(fixed)), worst_plain = std::max(worst_plain, std::abs(plain));
  }
  EXPECT_GT(worst_plain, 0.015);
  EXPECT_LT(worst_default, worst_plain / 5);
}

// Thin tubes: the torus R = 1, r = 0.1 (posed) at h = 0.05 and 0.0375, 4 and 5.3 voxels across,
// where the ball (l at the 4-voxel floor: k_R = 1, rho about 2.5) holds both sides of the tube.
// The plain estimator's area is 4-7% long there (posed: +5.0%, +3.6%; centred,
// bench/ii_radius_study.py --r 0.1: +6.7%, +6.4%); the default's 0.2-2.7% (posed: +1.1%, +0.2%;
// centred +2.7%, +2.5%). Asserted: the default's area error below 4% and
// below the plain's, and no more surfels of zero area than the plain's (the correction fades
// where the two least eigenvalues meet, as across a tube one or two voxels thick).
TEST(SurfaceNormals, ThinTubesKeepTheirArea) {
  auto tube = std::make_unique<Torus>(1.0, 0.1);
  const auto torus = posed(std::move(tube));
  for (double h : {0.05, 0.0375}) {
    const VoxelSet v = digitize(*torus, h);
    const SurfelSet f = extract_surfels(v);
    SurfaceNormalOptions o;
    const SurfelMeasures fixed = measures(f, ii_normals(v, f, o));
    o.remove_ball_anisotropy = false;
    const SurfelMeasures plain = measures(f, ii_normals(v, f, o));
    const double area = torus->area(), e_fixed = fixed.total_area() / area - 1, e_plain = plain.total_area() / area - 1;
    const auto zeros = [](const SurfelMeasures& m) { return (m.mu.array() == 0).count(); };
    std::printf("h = %g: area error %+.2f%% (plain %+.2f%%), zero areas %ld (plain %ld)\n", h, 100 * e_fixed, 100 * e_plain,
                static_cast<long>(zeros(fixed)), static_cast<long>(zeros(plain)));
    EXPECT_LT(std::abs(e_fixed), 0.04) << "h = " << h;
    EXPECT_LT(std::abs(e_fixed), std::abs(e_plain)) << "h = " << h;
    EXPECT_LE(zeros(fixed), zeros(plain)) << "h = " << h;
  }
}

// The default radius: k_R = 1 below l / h = 8 voxels, l / 2 between, k_R = 1.5 from 27 voxels on;
// a given k_R as it is.
TEST(SurfaceNormals, TheDefaultRadiusGrowsWithLOverH) {
  const auto unit = [](double h, double l) { return std::cbrt(h) * std::pow(l, 2.0 / 3.0); };
  EXPECT_DOUBLE_EQ(ii_ball_radius(0, 0.1, 0.5), unit(0.1, 0.5));        // l / h = 5
  EXPECT_DOUBLE_EQ(ii_ball_radius(0, 0.05, 1.0), 0.5);                  // l / h = 20: 1.36 h^(1/3)
  EXPECT_DOUBLE_EQ(ii_ball_radius(0, 0.01, 1.0), 1.5 * unit(0.01, 1.0));  // l / h = 100
  EXPECT_DOUBLE_EQ(ii_ball_radius(2.0, 0.01, 1.0), 2 * unit(0.01, 1.0));
  EXPECT_THROW(ii_ball_radius(-1, 0.1, 1.0), Error);
  EXPECT_THROW(ii_ball_radius(0, 0.1, 0.0), Error);
  EXPECT_THROW(ii_ball_radius(0, std::nan(""), 1.0), Error);
}

// Exact normals: unit, outward, along the surface normal at the closest point; the length scale
// as given and no II radius.
TEST(SurfaceNormals, ExactNormalsAreTheSurfacesAtTheClosestPoints) {
  const auto s = posed(make_surface("ellipsoid"));
  const SurfelSet f = extract_surfels(digitize(*s, 0.1));
  const SurfelNormals n = exact_normals(*s, f, 2.5);
  ASSERT_EQ(n.normals.rows(), static_cast<Eigen::Index>(f.size()));
  EXPECT_EQ(n.length_scale, 2.5);
  EXPECT_EQ(n.radius, 0.0);
  for (Eigen::Index i = 0; i < n.normals.rows(); ++i) {
    const Eigen::Vector3d c = f.centre(static_cast<std::size_t>(i));
    EXPECT_NEAR(n.normals.row(i).norm(), 1.0, 1e-12);
    EXPECT_LT((n.normals.row(i).transpose() - s->normal(s->closest_point(c))).norm(), 1e-12);
  }
}

// Without a length scale the exact normals measure it as the II normals do (issue 21), so that
// both give the same heat time: the same l and per-surface l_c, from the set or from the
// surface's own digitization.
TEST(SurfaceNormals, ExactNormalsMeasureTheLengthScaleLikeTheIIOnes) {
  const auto s = posed(make_surface("ellipsoid"));
  const VoxelSet v = digitize(*s, 0.08);
  const SurfelSet f = extract_surfels(v);
  const SurfelNormals ii = ii_normals(v, f), from_set = exact_normals(*s, v, f, {}), own = exact_normals(*s, f);
  EXPECT_GT(ii.length_scale, 0.0);
  EXPECT_EQ(from_set.length_scale, ii.length_scale);
  EXPECT_EQ(own.length_scale, ii.length_scale);
  EXPECT_EQ(own.surface_length_scales, ii.surface_length_scales);
  EXPECT_EQ(own.normals, exact_normals(*s, f, 1.0).normals);  // l changes nothing but l
  SurfaceNormalOptions given;
  given.length_scale = 0.7;
  EXPECT_EQ(exact_normals(*s, v, f, given).length_scale, 0.7);
  EXPECT_TRUE(exact_normals(*s, v, f, given).surface_length_scales.empty());
}

TEST(SurfaceNormals, BadRadiiAndLengthScalesAreRefused) {
  const VoxelSet v = digitize(Sphere(), 0.2);
  const SurfelSet f = extract_surfels(v);
  EXPECT_NE(error_of([&] { ii_normals(v, f, {-1.0, 1.0}); }).find("k_R"), std::string::npos);  // 0 is the default's rule
  EXPECT_THROW(ii_normals(v, f, {std::nan(""), 1.0}), Error);
  EXPECT_THROW(ii_normals(v, f, {1.0, -1.0}), Error);
  EXPECT_THROW(ii_normals(v, f, {50.0, 1.0}), Error);  // a ball wider than the whole set
  EXPECT_THROW(exact_normals(Sphere(), f, -1.0), Error);
  EXPECT_THROW(exact_normals(Sphere(), f, std::nan("")), Error);
}
