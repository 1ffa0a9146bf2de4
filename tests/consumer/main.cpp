// A program outside the project, linked through find_package(digilap CONFIG).
#include <digilap/digitization.hpp>
#include <digilap/shapes.hpp>

#include <cmath>
#include <cstdio>

int main() {
  digilap::Circle circle(1.0);
  const auto set = digilap::digitize(circle, 0.1);
  // 305 lattice points (i, j) with i^2 + j^2 < 100 (pixel centres strictly inside).
  std::printf("pixels: %lld\n", static_cast<long long>(set.pixel_count()));
  return set.pixel_count() == 305 ? 0 : 1;
}
