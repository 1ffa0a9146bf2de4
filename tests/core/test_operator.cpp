// The shared core (core/operator.hpp): what every operator is, and the one rule for elements of
// zero mass, through every downstream function, in both dimensions (issues 21 and 22).
#include "digilap/core/error.hpp"
#include "digilap/core/operator.hpp"
#include "digilap/core/heat_flow.hpp"
#include "digilap/curve/smoothing.hpp"
#include "digilap/curve/spectrum.hpp"
#include "digilap/surface/heat_laplacian.hpp"

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

using namespace digilap;

namespace {

// The surface of a unit sphere at h = 0.15 (about 900 surfels) with every 7th surfel's area set
// to 0, as thin parts of real labels give (their II normal orthogonal to the surfel).
surface::SurfaceOperator sphere_with_zero_areas(double scale_mass = 1.0) {
  surface::Sphere sphere;
  sphere.set_pose(Eigen::Vector3d(0.0123, -0.0371, 0.0217), Eigen::Matrix3d::Identity());
  const surface::VoxelSet voxels = surface::digitize(sphere, 0.15);
  const surface::SurfelSet surfels = surface::extract_surfels(voxels);
  surface::SurfelMeasures mu = surface::measures(surfels, surface::ii_normals(voxels, surfels));
  for (Eigen::Index i = 0; i < mu.mu.size(); i += 7) mu.mu[i] = 0;
  mu.mu *= scale_mass;
  return surface::heat_laplacian(surfels, mu);
}

// A flower's contour on its linels with every 5th linel measure set to 0.
ContourOperator flower_with_zero_lengths() {
  const DigitalSet set = digitize(Flower(), 0.05);
  const ContourSet cs = track_contours(set);
  Measures m = measures(cs, ii_normals(set, cs));
  for (auto& c : m.contours)
    for (std::size_t i = 0; i < c.linel_mu.size(); i += 5) c.linel_mu[i] = 0;
  HeatLaplacianOptions o;
  o.placement = Placement::Linels;
  return heat_laplacian(cs, m, o);
}

// The exact answer: the dense generalized problem on the rows with mass (the others deleted).
Eigen::VectorXd deleted_rows_eigenvalues(const HeatOperator& op, int count) {
  std::vector<Eigen::Index> keep;
  for (Eigen::Index i = 0; i < op.rows(); ++i)
    if (op.mass[i] > 0) keep.push_back(i);
  const auto n = static_cast<Eigen::Index>(keep.size());
  const Eigen::MatrixXd A(op.A);
  Eigen::MatrixXd K(n, n);
  Eigen::VectorXd m(n);
  for (Eigen::Index a = 0; a < n; ++a) {
    m[a] = op.mass[keep[a]];
    for (Eigen::Index b = 0; b < n; ++b) K(a, b) = -A(keep[a], keep[b]);
  }
  Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> eig(K, m.asDiagonal());
  return eig.eigenvalues().head(count);
}

// Each eigenpair: A x = -lambda M x on the support (relative to |A x|), and each zero-mass entry
// the heat-kernel average of its neighbours (its row of L): (L x)_i = 0.
void expect_solves_on_support(const HeatOperator& op, const Spectrum& s) {
  for (Eigen::Index k = 0; k < s.eigenvalues.size(); ++k) {
    const Eigen::VectorXd x = s.eigenvectors.col(k);
    const Eigen::VectorXd r = op.A * x + s.eigenvalues[k] * op.mass.cwiseProduct(x);
    EXPECT_LT(r.cwiseAbs().maxCoeff(), 1e-7 * std::max(1.0, (op.A * x).cwiseAbs().maxCoeff())) << "pair " << k;
    const Eigen::VectorXd Lx = op.L * x;
    for (Eigen::Index i : op.massless_rows())
      ASSERT_LT(std::abs(Lx[i]), 1e-12 * x.cwiseAbs().maxCoeff() * std::abs(op.L.coeff(i, i))) << "row " << i;
  }
}

}  // namespace

TEST(Operator, BothOperatorsAreHeatOperators) {
  const surface::SurfaceOperator s = sphere_with_zero_areas();
  EXPECT_EQ(s.dimension, 2);
  EXPECT_EQ(s.parts(), 1u);
  EXPECT_EQ(s.row_offset.back(), s.rows());
  EXPECT_EQ(s.time_of_part(0), s.t);
  EXPECT_EQ(static_cast<Eigen::Index>(s.massless_rows().size()), (s.rows() + 6) / 7);
  const ContourOperator c = flower_with_zero_lengths();
  EXPECT_EQ(c.dimension, 1);
  EXPECT_EQ(c.parts(), 1u);
  EXPECT_GT(c.massless_rows().size(), 10u);
}

// Zero masses (issue 22): the eigenvalues are those of the problem with the zero-mass rows
// deleted. 1e-10 relative: the Lanczos and LOBPCG tolerances are 1e-10 on the Ritz values, the
// dense reference is exact to rounding (1e-13 here).
TEST(Operator, ZeroAreasGiveTheSpectrumOfTheDeletedRows) {
  const surface::SurfaceOperator op = sphere_with_zero_areas();
  const int count = 9;
  const Eigen::VectorXd exact = deleted_rows_eigenvalues(op, count);
  for (SpectrumMethod method : {SpectrumMethod::Auto, SpectrumMethod::Factorization, SpectrumMethod::Products}) {
    SpectrumOptions o;
    o.count = count, o.method = method;
    const Spectrum s = smallest_eigenpairs(op, o);
    EXPECT_EQ(s.massless, static_cast<Eigen::Index>(op.massless_rows().size()));
    for (int k = 1; k < count; ++k) EXPECT_NEAR(s.eigenvalues[k], exact[k], 1e-10 * exact[k]) << "k " << k;
    EXPECT_NEAR(s.eigenvalues[0], 0.0, 1e-10 * exact[1]);
    expect_solves_on_support(op, s);
    EXPECT_TRUE(s.laplace_beltrami.allFinite());
    // M-orthonormal: zero-mass rows do not count in x^T M x.
    const Eigen::MatrixXd gram = s.eigenvectors.transpose() * op.mass.asDiagonal() * s.eigenvectors;
    EXPECT_LT((gram - Eigen::MatrixXd::Identity(count, count)).cwiseAbs().maxCoeff(), 1e-8);
  }
  // From (A, mass) alone the zero-mass entries are 0 (nothing tells their neighbours).
  const Spectrum raw = smallest_eigenpairs(op.A, op.mass, {count});
  for (Eigen::Index i : op.massless_rows()) EXPECT_EQ(raw.eigenvectors.row(i).cwiseAbs().maxCoeff(), 0.0);
}

TEST(Operator, ZeroLinelLengthsGiveTheSpectrumOfTheDeletedRows) {
  const ContourOperator op = flower_with_zero_lengths();
  const int count = 7;
  const Eigen::VectorXd exact = deleted_rows_eigenvalues(op, count);
  const Spectrum s = smallest_eigenpairs(op, {count});
  for (int k = 1; k < count; ++k) EXPECT_NEAR(s.eigenvalues[k], exact[k], 1e-10 * exact[k]) << "k " << k;
  expect_solves_on_support(op, s);
  const std::vector<Spectrum> per_part = smallest_eigenpairs_per_part(op, {count});
  ASSERT_EQ(per_part.size(), 1u);
  for (int k = 1; k < count; ++k) EXPECT_NEAR(per_part[0].eigenvalues[k], exact[k], 1e-10 * exact[k]);
  expect_solves_on_support(op, per_part[0]);
}

// Heat on zero-mass elements: conserved (sum mu u, to rounding) and, with implicit Euler, never
// negative from a non-negative start (the flow is monotone); smoothing goes through the same flow.
TEST(Operator, HeatFlowWithZeroMassesConservesAndStaysNonNegative) {
  const surface::SurfaceOperator sphere = sphere_with_zero_areas();
  const ContourOperator flower = flower_with_zero_lengths();
  for (const HeatOperator* op : {static_cast<const HeatOperator*>(&sphere), static_cast<const HeatOperator*>(&flower)}) {
    Eigen::VectorXd u0 = Eigen::VectorXd::Zero(op->rows());
    for (Eigen::Index i = 0; i < op->rows() / 10; ++i) u0[i] = 1.0;
    const HeatFlow flow(*op, 20 * op->t, TimeScheme::ImplicitEuler);
    const Eigen::VectorXd u = flow.advance(u0, 10);
    EXPECT_NEAR(op->mass.dot(u), op->mass.dot(u0), 1e-12 * op->mass.dot(u0));
    EXPECT_GE(u.minCoeff(), -1e-14);
    EXPECT_LE(u.maxCoeff(), 1 + 1e-14);
    EXPECT_LT((op->L * u).cwiseAbs().maxCoeff(), 1e30);  // finite everywhere
    for (Eigen::Index i : op->massless_rows()) EXPECT_GT(u[i], 0.0) << "row " << i;  // heat reached them
    const Eigen::VectorXd smoothed = smooth_function(*op, u0, 200 * op->t, 10);
    EXPECT_EQ(smoothed, u);
    // The raw pair (A, M) has no equation for those rows: refused, with the way out.
    try {
      HeatFlow(op->A, op->mass, op->t);
      ADD_FAILURE() << "expected digilap::Error";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("HeatFlow(op, dt)"), std::string::npos) << e.what();
    }
  }
}

// A part with no mass at all has no spectrum and no flow: refused, not a silent answer.
TEST(Operator, APartWithNoMassIsRefused) {
  surface::SurfaceOperator op = sphere_with_zero_areas();
  op.mass.setZero();
  op.A = 0.0 * op.A;
  for (Eigen::Index i = 0; i < op.rows(); ++i) {  // L_ij = w_ij mu_j = 0
    for (SparseMatrix::InnerIterator it(op.L, i); it; ++it) it.valueRef() = 0;
  }
  op.mass[0] = 1e-3;  // one element with mass: the others are away from it by more than the cut
  try {
    smallest_eigenpairs(op, {1});
    ADD_FAILURE() << "expected digilap::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no neighbour with mass"), std::string::npos) << e.what();
  }
  EXPECT_THROW(HeatFlow(op, 0.1), Error);
  Eigen::VectorXd negative = op.mass;
  negative[3] = -1;
  EXPECT_THROW(smallest_eigenpairs(op.A, negative, {1}), Error);
  negative[3] = std::nan("");
  EXPECT_THROW(smallest_eigenpairs(op.A, negative, {1}), Error);
}

// The Lanczos shift follows the spectrum's units (issue 21): a surface's masses scaled by s^2
// (a sphere of radius s, A unchanged) scale every eigenvalue by 1 / s^2, and the shift-invert
// iteration is the same one, operation for operation. With the shift of a curve,
// (2 pi / sum mu)^2, sigma / lambda_1 would go from -1.25e-3 to -1.25e-7 at s = 100.
TEST(Operator, SpectralShiftIsScaleInvariantOnSurfaces) {
  const surface::SurfaceOperator unit = sphere_with_zero_areas();
  SpectrumOptions o;
  o.count = 9, o.method = SpectrumMethod::Factorization, o.dimension = 2;
  const Spectrum a = smallest_eigenpairs(unit.A, unit.mass, o);
  const Spectrum b = smallest_eigenpairs(unit.A, 1e4 * unit.mass, o);
  for (int k = 1; k < o.count; ++k) EXPECT_NEAR(b.eigenvalues[k] * 1e4, a.eigenvalues[k], 1e-10 * a.eigenvalues[k]);
  EXPECT_EQ(a.operations, b.operations);
  EXPECT_EQ(a.iterations, b.iterations);
}

// One memory check for every operator, with the 2^31-nonzero guard of int row offsets (2D
// lacked it, while its message advised raising the limit).
TEST(Operator, MemoryCheckRefusesTwoToTheThirtyOneNonzeros) {
  const std::size_t too_many = static_cast<std::size_t>(std::numeric_limits<int>::max()) + 1;
  try {
    detail::check_operator_memory("heat_laplacian", too_many, 1000, 1e300, true, "use a coarser h");
    ADD_FAILURE() << "expected digilap::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("2^31"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find("raise memory_limit_bytes"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(detail::check_operator_memory("heat_laplacian", too_many - 1, 1000, 1e300, true, ""));
  EXPECT_THROW(detail::check_operator_memory("heat_laplacian", 1000, 10, 1.0, true, ""), Error);
}
