// Heat flow: decay of the first mode against exp(-(2 pi / P)^2 tau); schemes compared.
#include "digilap/core/error.hpp"
#include "digilap/curve/ground_truth.hpp"
#include "digilap/core/heat_flow.hpp"
#include "digilap/curve/heat_laplacian.hpp"
#include "digilap/curve/spectrum.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace digilap;

namespace {
constexpr double kPi = 3.14159265358979323846;
struct FlowSetup {
  ContourOperator op;
  Eigen::VectorXd u0;
};
FlowSetup flower_cosine(double h) {
  Flower flower;
  const DigitalSet set = digitize(flower, h);
  const ContourSet cs = track_contours(set);
  FlowSetup s{heat_laplacian(cs, measures(cs, ii_normals(set, cs))), {}};
  s.u0 = sample_values(flower, intrinsic_cosine(1), sample_parameters(flower, s.op.positions));
  return s;
}
}  // namespace

TEST(HeatFlow, FirstModeDecaysAsTheExactExponential) {
  Flower flower;
  const FlowSetup s = flower_cosine(0.01);
  const double tau = 0.5, exact = std::exp(-std::pow(2 * kPi / flower.length(), 2) * tau);
  const Eigen::VectorXd euler = HeatFlow(s.op, tau / 100, TimeScheme::ImplicitEuler).advance(s.u0, 100);
  const Eigen::VectorXd cn = HeatFlow(s.op, tau / 100, TimeScheme::CrankNicolson).advance(s.u0, 100);
  const double a_euler = modal_amplitude(euler, s.u0, s.op.mass), a_cn = modal_amplitude(cn, s.u0, s.op.mass);
  EXPECT_NEAR(a_euler, exact, 0.02 * exact);
  EXPECT_NEAR(a_cn, exact, 0.02 * exact);
  std::printf("flower h = 0.01, amplitude after tau = 0.5: exact %.6f, Euler %.6f, Crank-Nicolson %.6f\n", exact,
              a_euler, a_cn);
}

TEST(HeatFlow, CrankNicolsonIsCloserToTheExactFlowThanEuler) {
  // Against exp(tau L) u0 of the same discrete operator (dense, N = 1052): the time error alone.
  const FlowSetup s = flower_cosine(0.02);
  const double tau = 0.5;
  const Eigen::VectorXd euler = HeatFlow(s.op, tau / 100, TimeScheme::ImplicitEuler).advance(s.u0, 100);
  const Eigen::VectorXd cn = HeatFlow(s.op, tau / 100, TimeScheme::CrankNicolson).advance(s.u0, 100);
  const Eigen::VectorXd reference = heat_flow_dense(s.op.A, s.op.mass, s.u0, tau);
  const double e_euler = (euler - reference).cwiseAbs().maxCoeff(), e_cn = (cn - reference).cwiseAbs().maxCoeff();
  // First order vs second order in dt = 5e-3: CN is orders of magnitude closer.
  EXPECT_LT(e_cn, 0.01 * e_euler);
  std::printf("max deviation from exp(tau L) u0: Euler %.2e, Crank-Nicolson %.2e\n", e_euler, e_cn);
}

TEST(HeatFlow, SpectralFlowMatchesDenseFlowOnTheModesItSpans) {
  const FlowSetup s = flower_cosine(0.02);
  const Spectrum sp = smallest_eigenpairs(s.op, {12});
  // u0 = a combination of the computed modes: exact through the eigenbasis.
  const Eigen::VectorXd u0 = sp.eigenvectors.col(1) + 0.5 * sp.eigenvectors.col(4) - 0.2 * sp.eigenvectors.col(9);
  const Eigen::VectorXd a = heat_flow_spectral(sp, s.op.mass, u0, 0.3);
  const Eigen::VectorXd b = heat_flow_dense(s.op.A, s.op.mass, u0, 0.3);
  EXPECT_LE((a - b).cwiseAbs().maxCoeff(), 1e-8 * u0.cwiseAbs().maxCoeff());
}

TEST(HeatFlow, ConservesTheTotalHeatAndRefusesBadSteps) {
  const FlowSetup s = flower_cosine(0.02);
  const Eigen::VectorXd bump = (s.op.positions.col(0).array() > 1.5).cast<double>();
  const Eigen::VectorXd u = HeatFlow(s.op, 0.01).advance(bump, 20);
  // Rows of A sum to zero, so M u is conserved: 1^T M u_{n+1} = 1^T M u_n.
  EXPECT_NEAR(s.op.mass.dot(u), s.op.mass.dot(bump), 1e-12 * s.op.mass.dot(bump));
  EXPECT_LE(u.maxCoeff(), 1.0 + 1e-12);  // maximum principle (nonnegative weights)
  EXPECT_THROW(HeatFlow(s.op, 0.0), Error);
  EXPECT_THROW(HeatFlow(s.op, -1.0), Error);
  EXPECT_THROW(HeatFlow(s.op, std::nan("")), Error);
}

// Issue 15, item 5: one huge step used to create heat (0.76 -> 0.83 at dt = 1e13) and make a
// bump negative (total -0.28 at dt = 1e15). Now each contour keeps its heat to rounding for
// every dt, and implicit Euler, monotone, keeps a non-negative bump non-negative: after a step
// that long it is the contour's mean. Two contours (a disc inside an annulus) keep theirs apart.
TEST(HeatFlow, HugeStepsConserveTheHeatOfEachContour) {
  std::vector<std::uint8_t> bits(40 * 40, 0);
  for (int r = 0; r < 40; ++r)
    for (int c = 0; c < 40; ++c) {
      const double d = std::hypot(r - 19.5, c - 19.5);
      bits[r * 40 + c] = (d < 18 && d > 11) || d < 6;
    }
  const DigitalSet set = DigitalSet::from_bitmap(0.05, 40, 40, bits);
  const ContourSet cs = track_contours(set);
  ASSERT_EQ(cs.contours.size(), 3u);
  IINormalOptions normal_options;
  normal_options.k_R = 0.3;
  const ContourOperator op = heat_laplacian(cs, measures(cs, ii_normals(set, cs, normal_options)));
  Eigen::VectorXd bump = Eigen::VectorXd::Zero(op.rows());
  for (Eigen::Index r = 0; r < op.rows(); ++r) bump[r] = std::max(0.0, 1.0 - std::abs(op.positions(r, 0) - 0.9) / 0.4);
  auto heat_of = [&](const Eigen::VectorXd& u, std::size_t c) {
    const Eigen::Index a = op.row_offset[c], n = op.row_offset[c + 1] - a;
    return op.mass.segment(a, n).dot(u.segment(a, n));
  };
  for (double dt : {1e-3, 1e6, 1e13, 1e15, 1e30})
    for (auto scheme : {TimeScheme::ImplicitEuler, TimeScheme::CrankNicolson}) {
      const Eigen::VectorXd u = HeatFlow(op, dt, scheme).step(bump);
      for (std::size_t c = 0; c < cs.contours.size(); ++c)
        // Sums of a few hundred terms of size <= 1: rounding near 1e-15 relative.
        EXPECT_NEAR(heat_of(u, c), heat_of(bump, c), 1e-12 * std::max(1.0, heat_of(bump, c))) << "dt = " << dt << ", contour " << c;
      if (scheme == TimeScheme::ImplicitEuler) EXPECT_GE(u.minCoeff(), -1e-12) << "dt = " << dt;
      if (scheme == TimeScheme::ImplicitEuler && dt >= 1e13)
        for (std::size_t c = 0; c < cs.contours.size(); ++c) {
          const Eigen::Index a = op.row_offset[c], n = op.row_offset[c + 1] - a;
          const double mean = heat_of(bump, c) / op.mass.segment(a, n).sum();
          EXPECT_LE((u.segment(a, n).array() - mean).abs().maxCoeff(), 1e-9) << "dt = " << dt << ", contour " << c;
        }
    }
}
