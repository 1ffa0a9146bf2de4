// A program outside the project, linked through find_package(digilap CONFIG). It uses both the
// layered headers (digilap/curve/, digilap/core/, digilap/surface/) and the 2D paths and names of
// earlier releases, which are kept for one release (forwarding headers, inline namespace curve).
#include <digilap/core/spectrum.hpp>
#include <digilap/curve/digitization.hpp>
#include <digilap/surface/digitization.hpp>

#include <digilap/digitization.hpp>  // the earlier path
#include <digilap/shapes.hpp>        // the earlier path

#include <cmath>
#include <cstdio>
#include <type_traits>

int main() {
  static_assert(std::is_same_v<digilap::Circle, digilap::curve::Circle>, "one type under both names");
  digilap::curve::Circle circle(1.0);
  const auto set = digilap::digitize(circle, 0.1);
  const auto same = digilap::curve::digitize(circle, 0.1);
  const auto ball = digilap::surface::digitize(digilap::surface::Sphere(1.0), 0.25);
  // 305 lattice points (i, j) with i^2 + j^2 < 100 (pixel centres strictly inside), under both
  // names; 251 points (i, j, k) with i^2 + j^2 + k^2 < 16.
  std::printf("pixels: %lld, voxels: %lld\n", static_cast<long long>(set.pixel_count()),
              static_cast<long long>(ball.voxel_count()));
  return set.pixel_count() == 305 && same.pixel_count() == 305 && ball.voxel_count() == 251 ? 0 : 1;
}
