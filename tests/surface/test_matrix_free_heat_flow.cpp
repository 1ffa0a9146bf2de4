// surface/matrix_free_heat_flow.hpp: heat flow and smoothing without storing L, against the
// assembled operator's flow, on two surfaces and on a real label with zero-area surfels.
#include "digilap/core/smoothing.hpp"
#include "digilap/surface/matrix_free_heat_flow.hpp"
#include "on_threads.hpp"
#include "support.hpp"

#include <gtest/gtest.h>

using namespace digilap;
using namespace digilap::surface;
using namespace digilap::surface::test_support;

// Heat flow without storing L (issue 23): 10 Crank-Nicolson steps of dt = t on two surfaces
// and on a real label with zero-area surfels give the assembled HeatFlow's state (also by CG,
// and with the same treatment of zero areas) to 1e-9 of its size: both solve each step to 1e-12
// relative residual, and the products agree to 1e-14 (a contraction adds at most the steps'
// errors). Each surface's heat sum mu u is kept to 1e-12, the bits are the same for 1 and 2
// threads, and smoothing equals the assembled smooth() to the same 1e-9.
TEST(MatrixFreeSurface, HeatFlowEqualsTheAssembledFlow) {
  for (const VoxelSet& set : {two_balls(), real_label()}) {
    const Pipeline p = filtered(set);
    const SurfaceOperator op = heat_laplacian(p.surfels, p.mu);
    const MatrixFreeSurfaceOperator free(p.surfels, p.mu);
    Eigen::VectorXd u0(op.rows());
    for (Eigen::Index i = 0; i < u0.size(); ++i) u0[i] = std::exp(-0.05 * (op.positions.row(i) - op.positions.row(0)).squaredNorm());
    const double dt = op.t;
    const Eigen::VectorXd reference = HeatFlow(op, dt).advance(u0, 10);
    const MatrixFreeHeatFlow flow(free, dt);
    const Eigen::VectorXd u = flow.advance(u0, 10);
    EXPECT_LT((u - reference).cwiseAbs().maxCoeff(), 1e-9 * reference.cwiseAbs().maxCoeff());
    EXPECT_GT(flow.last_iterations(), 0);
    for (std::size_t s = 0; s < op.parts(); ++s) {
      const Eigen::Index first = op.row_offset[s], count = op.row_offset[s + 1] - first;
      const double before = op.mass.segment(first, count).dot(u0.segment(first, count));
      EXPECT_NEAR(op.mass.segment(first, count).dot(u.segment(first, count)), before, 1e-12 * std::abs(before)) << "surface " << s;
    }
    EXPECT_EQ(on_threads(1, [&] { return flow.advance(u0, 3); }), on_threads(2, [&] { return flow.advance(u0, 3); }));
    const Eigen::MatrixXd f = block(op.rows(), 2);
    const Eigen::MatrixXd smoothed = smooth(free, f, 3 * op.t, 3), assembled = digilap::smooth(op, f, 3 * op.t, 3);
    EXPECT_LT((smoothed - assembled).cwiseAbs().maxCoeff(), 1e-9 * assembled.cwiseAbs().maxCoeff());
  }
  const MatrixFreeSurfaceOperator free(filtered(two_balls()).surfels, filtered(two_balls()).mu);
  EXPECT_THROW(MatrixFreeHeatFlow(free, 0.0), Error);
  EXPECT_THROW(MatrixFreeHeatFlow(free, 1.0).step(Eigen::VectorXd::Zero(3)), Error);
  EXPECT_THROW(smooth(free, Eigen::MatrixXd::Zero(free.rows(), 1), -1.0), Error);
}
