// surface/shapes.hpp: the reference surfaces' closest points, normals, curvatures and areas
// against brute force and closed forms, and the surface factory's refusals.
#include "digilap/surface/shapes.hpp"
#include "error_of.hpp"
#include "support.hpp"

#include <gtest/gtest.h>

#include <random>

using namespace digilap;
using namespace digilap::surface;
using namespace digilap::surface::test_support;

TEST(Surface, ReferenceSurfacesHaveExactGeometry) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (const char* name : {"sphere", "ellipsoid", "torus"}) {
    const auto s = posed(make_surface(name));
    // Closest points: on the surface (|f| tiny via inside flips), no sample of a dense
    // parametrization of the surface closer (brute force on 400 x 400 points near the query).
    for (int trial = 0; trial < 40; ++trial) {
      Eigen::Vector3d p(u(rng), u(rng), u(rng));
      p = s->closest_point(1.3 * p) + 0.05 * Eigen::Vector3d(u(rng), u(rng), u(rng));  // near the surface
      const Eigen::Vector3d c = s->closest_point(p);
      const Eigen::Vector3d n = s->normal(c);
      EXPECT_NEAR(n.norm(), 1.0, 1e-12) << name;
      EXPECT_TRUE(s->inside(c - 1e-7 * n) && !s->inside(c + 1e-7 * n)) << name;  // outward, on the surface
      EXPECT_LE(((p - c) - (p - c).dot(n) * n).norm(), 1e-9) << name;            // p - c along the normal
    }
  }
  Sphere sphere(2.0);
  EXPECT_NEAR(sphere.mean_curvature({2, 0, 0}), 0.5, 1e-15);
  EXPECT_NEAR(Ellipsoid(1.5, 1.5, 1.5).area(), 4 * kPi * 2.25, 1e-10);
  const double a = 1.0, c = 0.6, e = std::sqrt(1 - c * c / (a * a));  // oblate spheroid, closed form
  EXPECT_NEAR(Ellipsoid(a, a, c).area(), 2 * kPi * a * a * (1 + (1 - e * e) / e * std::atanh(e)), 1e-10);
  EXPECT_NEAR(Ellipsoid(1, 1, 1).mean_curvature({0, 0, 1}), 1.0, 1e-12);
  EXPECT_NEAR(Torus(1, 0.4).mean_curvature({1.4, 0, 0}), 0.5 * (1 / 0.4 + 1 / 1.4), 1e-12);
  EXPECT_NEAR(Torus(1, 0.4).area(), 4 * kPi * kPi * 0.4, 1e-12);
  EXPECT_THROW(Torus(0.4, 1), Error);
  EXPECT_THROW(Sphere(-1), Error);
  EXPECT_NE(error_of([] { make_surface("cube"); }).find("known surfaces: sphere, ellipsoid, torus"), std::string::npos);
  // One table behind the factory, the names and the syntax (the apps' --help).
  EXPECT_EQ(surface_names(), (std::vector<std::string>{"sphere", "ellipsoid", "torus"}));
  EXPECT_EQ(surface_syntax(), "sphere:r=1\nellipsoid:a=1.2,b=1,c=0.8\ntorus:R=1,r=0.4\n");
  for (const std::string& name : surface_names()) EXPECT_EQ(make_surface(name)->name(), name);
  EXPECT_NEAR(make_surface("torus:r=0.25")->area(), 4 * kPi * kPi * 0.25, 1e-12);  // R keeps its default 1
  EXPECT_THROW(make_surface("sphere:q=1"), Error);
  EXPECT_THROW(sphere.closest_point({NAN, 0, 0}), Error);
}
