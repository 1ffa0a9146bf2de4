#include "digilap/curve/spectrum.hpp"

#include "digilap/core/constants.hpp"

#include <cmath>

namespace digilap {
inline namespace curve {

double heat_kernel_eigenvalue(int m, double P, double t) {
  const double w = 2 * kPi * m / P, w2 = w * w;
  if (t == 0) return w2;
  return -std::expm1(-w2 * t) / t;
}

}  // namespace curve
}  // namespace digilap
