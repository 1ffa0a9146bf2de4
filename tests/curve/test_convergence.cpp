// The sweep machinery of the convergence experiment, on coarse grids (fast).
#include "digilap/curve/convergence.hpp"
#include "digilap/core/error.hpp"

#include <gtest/gtest.h>

using namespace digilap;

TEST(Convergence, HeatLaplacianConvergesAndNaiveDecDoesNotOnTheCircle) {
  Circle circle;
  ConvergenceOptions o;
  o.steps = {0.1, 0.05, 0.02, 0.01, 0.005};
  o.variants = {operator_variant("geodesic"), operator_variant("dec-naive")};
  int calls = 0;
  o.progress = [&](double) { ++calls; };
  const ConvergenceResult r = convergence_sweep(circle, ambient_x2(), o);
  EXPECT_EQ(calls, 10);
  ASSERT_EQ(r.rows.size(), 10u);
  // The paper's claim: the heat Laplacian converges (slope ~2/3), DEC does not.
  EXPECT_GT(r.slope("geodesic"), 0.5);
  EXPECT_LT(r.slope("dec-naive"), 0.2);
  // Rows are consistent with the grid: about 4 * perimeter / (pi h)... elements grow like 1/h.
  const auto g = r.of("geodesic");
  ASSERT_EQ(g.size(), 5u);
  for (std::size_t i = 1; i < g.size(); ++i) {
    EXPECT_LT(g[i].h, g[i - 1].h);
    EXPECT_NEAR(static_cast<double>(g[i].elements) * g[i].h, static_cast<double>(g[0].elements) * g[0].h,
                0.1 * static_cast<double>(g[0].elements) * g[0].h);
    EXPECT_NEAR(g[i].length_estimate, g[i].length_exact, 0.02 * g[i].length_exact);
  }
}

TEST(Convergence, SlopeIsTheLeastSquaresFitOfLogErrorAgainstLogH) {
  ConvergenceResult r;
  // err = 3 h^0.7 exactly, then an outlier at the coarsest step that only the full fit sees.
  for (double h : {0.1, 0.01, 0.001, 0.0001}) {
    ConvergenceRow row;
    row.h = h;
    row.variant = "v";
    row.relative_max_error = 3 * std::pow(h, 0.7) * (h == 0.1 ? 10.0 : 1.0);
    r.rows.push_back(row);
  }
  EXPECT_NEAR(r.slope("v", 3), 0.7, 1e-12);
  EXPECT_GT(r.slope("v"), 0.9);
}

TEST(Convergence, VariantsByNameAndClearErrors) {
  EXPECT_EQ(operator_variant("dgtal").heat.placement, Placement::Linels);
  EXPECT_EQ(operator_variant("dgtal").heat.distance, DistanceMode::Euclidean);
  EXPECT_TRUE(operator_variant("geodesic-exact").exact_normals);
  EXPECT_TRUE(operator_variant("richardson-euclidean").heat.richardson);
  EXPECT_FALSE(operator_variant("euclidean").heat.richardson);
  EXPECT_THROW(operator_variant("cotan"), Error);
  ConvergenceOptions o;
  o.variants = {operator_variant("geodesic")};
  o.steps.clear();
  EXPECT_THROW(convergence_sweep(Circle(), ambient_x2(), o), Error);
}

TEST(Convergence, RichardsonMeetsTheOnePercentTargetOnTheFlower) {
  // Issue 4's target: g = x^2 on the flower at issue 4's parameters (t = 0.03 h^(2/3),
  // R = h^(1/3), k = 6, i.e. length scale 1): at most 1% at h = 0.001 and a fitted slope of at
  // least 0.6 over h = 0.1 .. 0.001 (docs/accuracy.md: 0.80%, slope 1.02). The plain operator
  // gives 1.93% there: its O(t) bias is what Richardson cancels.
  ConvergenceOptions o;
  o.ii = {1.0, 1.0};
  HeatLaplacianOptions former;
  former.c_t = 0.03;
  former.length_scale = 1.0;
  o.variants = {operator_variant("richardson-euclidean", former)};
  const ConvergenceResult r = convergence_sweep(Flower(), ambient_x2(), o);
  EXPECT_LE(r.of("richardson-euclidean").back().relative_max_error, 0.01);
  EXPECT_GE(r.slope("richardson-euclidean"), 0.6);
}
