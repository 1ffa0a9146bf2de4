// The matrix-free operator against the explicit matrix; spectrum and CG heat step through it.
#include "digilap/error.hpp"
#include "digilap/ground_truth.hpp"
#include "digilap/heat_flow.hpp"
#include "digilap/matrix_free.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace digilap;

namespace {
constexpr double kPi = 3.14159265358979323846;
struct Pipeline {
  ContourSet contours;
  Measures mu;
};
Pipeline pipeline(const Shape& shape, double h) {
  const DigitalSet set = digitize(shape, h);
  Pipeline s{track_contours(set), {}};
  s.mu = measures(s.contours, ii_normals(set, s.contours));
  return s;
}
}  // namespace

TEST(MatrixFree, AgreesWithTheExplicitOperatorToEpsilonOnEveryReferenceShape) {
  for (const auto& name : shape_names()) {
    auto shape = make_shape(name);
    for (double h : {0.02, 0.005}) {
      const Pipeline s = pipeline(*shape, h);
      for (auto placement : {Placement::Pointels, Placement::Linels}) {
        HeatLaplacianOptions o;
        o.placement = placement;
        const ContourOperator op = heat_laplacian(s.contours, s.mu, o);
        const MatrixFreeLaplacian mf(s.contours, s.mu, o, 1e-10);
        ASSERT_EQ(mf.rows(), op.rows());
        // A smooth function and a rough one: agreement relative to the operator's scale.
        const Eigen::VectorXd smooth = sample_values(*shape, ambient_x2(), sample_parameters(*shape, op.positions));
        const Eigen::VectorXd rough = Eigen::VectorXd::Random(op.rows());
        for (const Eigen::VectorXd& g : {smooth, rough}) {
          const double scale = op.L.diagonal().cwiseAbs().maxCoeff() * g.cwiseAbs().maxCoeff();
          EXPECT_LE((mf * g - op.L * g).cwiseAbs().maxCoeff(), 1e-10 * scale) << name << " h " << h;
        }
        EXPECT_LE((mf.diagonal() - Eigen::VectorXd(op.L.diagonal())).cwiseAbs().maxCoeff(),
                  1e-10 * op.L.diagonal().cwiseAbs().maxCoeff());
        EXPECT_LE((mf.apply_stiffness(rough) - op.A * rough).cwiseAbs().maxCoeff(),
                  1e-10 * op.A.diagonal().cwiseAbs().maxCoeff() * rough.cwiseAbs().maxCoeff());
      }
    }
  }
}

TEST(MatrixFree, AccuracyFollowsEpsilon) {
  const Pipeline s = pipeline(Flower(), 0.005);
  const ContourOperator op = heat_laplacian(s.contours, s.mu);
  const Eigen::VectorXd g = Eigen::VectorXd::Random(op.rows());
  const double scale = op.L.diagonal().cwiseAbs().maxCoeff() * g.cwiseAbs().maxCoeff();
  for (double eps : {1e-4, 1e-7}) {
    const MatrixFreeLaplacian mf(s.contours, s.mu, {}, eps);
    const double err = (mf * g - op.L * g).cwiseAbs().maxCoeff() / scale;
    EXPECT_LE(err, eps);
    EXPECT_LT(mf.order(), MatrixFreeLaplacian(s.contours, s.mu, {}, 1e-10).order());
  }
}

TEST(MatrixFree, WindowWiderThanHalfTheContourIsSummedDirectly) {
  const Pipeline s = pipeline(Circle(0.1), 0.01);
  HeatLaplacianOptions o;
  o.t = 0.01;  // cut 0.6 > P / 2
  const ContourOperator op = heat_laplacian(s.contours, s.mu, o);
  const MatrixFreeLaplacian mf(s.contours, s.mu, o);
  const Eigen::VectorXd g = Eigen::VectorXd::Random(op.rows());
  EXPECT_LE((mf * g - op.L * g).cwiseAbs().maxCoeff(), 1e-12 * op.L.diagonal().cwiseAbs().maxCoeff());
}

TEST(MatrixFree, SmallestEigenpairsMatchTheExactSpectrum) {
  Flower flower;
  const Pipeline s = pipeline(flower, 0.01);
  const MatrixFreeLaplacian mf(s.contours, s.mu);
  const Spectrum sp = smallest_eigenpairs(mf, {9});
  EXPECT_LE(std::abs(sp.eigenvalues[0]), 1e-6);
  for (int m = 1; m <= 4; ++m) {
    const double exact = std::pow(2 * kPi * m / flower.length(), 2);
    for (int k : {2 * m - 1, 2 * m}) EXPECT_NEAR(sp.eigenvalues[k], exact, 0.01 * exact) << "m = " << m;
  }
  // M-orthonormal eigenvectors.
  const Eigen::MatrixXd gram = sp.eigenvectors.transpose() * mf.mass().asDiagonal() * sp.eigenvectors;
  EXPECT_LE((gram - Eigen::MatrixXd::Identity(9, 9)).cwiseAbs().maxCoeff(), 1e-8);
}

TEST(MatrixFree, ConjugateGradientHeatStepEqualsTheFactorizedOne) {
  const Pipeline s = pipeline(Flower(), 0.01);
  const ContourOperator op = heat_laplacian(s.contours, s.mu);
  const MatrixFreeLaplacian mf(s.contours, s.mu);
  const Eigen::VectorXd u = Eigen::VectorXd::Random(op.rows());
  int iterations = 0;
  const Eigen::VectorXd cg = heat_step_cg(mf, u, 0.01, 1e-12, &iterations);
  const Eigen::VectorXd direct = HeatFlow(op, 0.01, TimeScheme::ImplicitEuler).step(u);
  EXPECT_LE((cg - direct).cwiseAbs().maxCoeff(), 1e-8 * u.cwiseAbs().maxCoeff());
  EXPECT_GT(iterations, 0);
  EXPECT_THROW(heat_step_cg(mf, u, -1.0), Error);
}

TEST(MatrixFree, RefusesWhatIsNotAConvolution) {
  const Pipeline s = pipeline(Circle(), 0.05);
  HeatLaplacianOptions euclidean;
  euclidean.distance = DistanceMode::Euclidean;
  EXPECT_THROW(MatrixFreeLaplacian(s.contours, s.mu, euclidean), Error);
  HeatLaplacianOptions richardson;
  richardson.richardson = true;
  EXPECT_THROW(MatrixFreeLaplacian(s.contours, s.mu, richardson), Error);
  EXPECT_THROW(MatrixFreeLaplacian(s.contours, s.mu, {}, 0.0), Error);
}
