// curve/spectrum.hpp: the closed curve's heat-kernel eigenvalues (SPEC §5) against their limits,
// the circle's spectrum against them, and the per-contour name of earlier releases.
#include "digilap/curve/spectrum.hpp"
#include "digilap/core/constants.hpp"
#include "digilap/curve/contour.hpp"
#include "digilap/curve/measures.hpp"
#include "digilap/curve/normals.hpp"
#include "digilap/curve/shapes.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

using namespace digilap;

// (1 - exp(-w^2 t)) / t with w = 2 pi m / P: w^2 at t = 0; w^2 (1 - w^2 t / 2 + ...) for small
// w^2 t, to full precision (expm1: 1 - exp would lose the digits there); 1 / t for large w^2 t.
TEST(CurveSpectrum, HeatKernelEigenvalueHasItsLimits) {
  const double P = 3.0, w2 = std::pow(2 * kPi * 2 / P, 2);
  EXPECT_EQ(heat_kernel_eigenvalue(0, P, 0.01), 0.0);
  EXPECT_NEAR(heat_kernel_eigenvalue(2, P, 0.0), w2, 1e-14 * w2);
  const double tiny = 1e-12;
  EXPECT_NEAR(heat_kernel_eigenvalue(2, P, tiny), w2 * (1 - w2 * tiny / 2), 1e-15 * w2);
  EXPECT_NEAR(heat_kernel_eigenvalue(2, P, 0.01), (1 - std::exp(-w2 * 0.01)) / 0.01, 1e-13 * w2);
  EXPECT_NEAR(heat_kernel_eigenvalue(2000, P, 1.0), 1.0, 1e-15);
}

namespace {
ContourOperator operator_of(const Shape& shape, double h) {
  const DigitalSet set = digitize(shape, h);
  const ContourSet cs = track_contours(set);
  return heat_laplacian(cs, measures(cs, ii_normals(set, cs)));
}
}  // namespace

TEST(CurveSpectrum, CircleEigenvaluesMatchTheHeatKernelFormula) {
  Circle circle;
  const ContourOperator op = operator_of(circle, 0.01);
  SpectrumOptions so;
  so.count = 11;
  const Spectrum s = smallest_eigenpairs(op, so);
  ASSERT_EQ(s.eigenvalues.size(), 11);
  const double P = op.contour_length[0];
  // m = 0 (the constants), then pairs m = 1..5: within 2% of (1 - exp(-omega^2 t)) / t with the
  // estimated length P (SPEC §5: the spectrum's accuracy is that of P).
  EXPECT_LE(std::abs(s.eigenvalues[0]), 1e-8 * s.eigenvalues[1]);
  for (int m = 1; m <= 5; ++m) {
    const double expected = heat_kernel_eigenvalue(m, P, op.t);
    for (int k : {2 * m - 1, 2 * m}) EXPECT_NEAR(s.eigenvalues[k], expected, 0.02 * expected) << "m = " << m;
    const double split = std::abs(s.eigenvalues[2 * m] - s.eigenvalues[2 * m - 1]) / expected;
    // Odd m: the square symmetry of the grid makes the pair exactly degenerate.
    if (m % 2 == 1) EXPECT_LE(split, 1e-8) << "m = " << m;
    std::printf("circle h = 0.01: m = %d, lambda = %.6f, %.6f (formula %.6f), relative split %.2e\n", m,
                s.eigenvalues[2 * m - 1], s.eigenvalues[2 * m], expected, split);
  }
}

// The earlier name is the core's per-part spectrum, bit for bit.
TEST(CurveSpectrum, PerContourIsPerPart) {
  const DigitalSet set = DigitalSet::from_pixels(0.05, [] {
    std::vector<Eigen::Vector2i> p;
    for (int j = -12; j <= 12; ++j)
      for (int i = -30; i <= 30; ++i)
        if ((i + 15) * (i + 15) + j * j < 100 || (i - 15) * (i - 15) + j * j < 64) p.emplace_back(i, j);
    return p;
  }());
  const ContourSet cs = track_contours(set);
  ASSERT_EQ(cs.contours.size(), 2u);
  const ContourOperator op = heat_laplacian(cs, measures(cs, ii_normals(set, cs)));
  SpectrumOptions so;
  so.count = 4;
  const std::vector<Spectrum> a = smallest_eigenpairs_per_contour(op, so), b = smallest_eigenpairs_per_part(op, so);
  ASSERT_EQ(a.size(), 2u);
  for (std::size_t c = 0; c < 2; ++c) {
    EXPECT_EQ(a[c].eigenvalues, b[c].eigenvalues);
    EXPECT_EQ(a[c].eigenvectors, b[c].eigenvectors);
  }
}
