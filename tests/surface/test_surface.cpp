// Digital surfaces in 3D (SPEC §7, issue 13): reference surfaces, Gauss digitization, surfels,
// II normals, areas, the heat-kernel operator against the exact Laplace-Beltrami operator and
// against an independent NumPy implementation of SPEC §7 (the figures issue 13 quotes).
#include "digilap/core/error.hpp"
#include "digilap/core/heat_flow.hpp"
#include "digilap/curve/spectrum.hpp"
#include "digilap/surface/heat_laplacian.hpp"
#include "digilap/surface/ply.hpp"
#include "digilap/surface/smoothing.hpp"
#include "digilap/surface/volume.hpp"
#include "error_of.hpp"
#include "on_threads.hpp"

#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <nifti1.h>
#include <nifti2.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include <omp.h>
#include <zlib.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <tuple>
#include <random>

using namespace digilap;
using namespace digilap::surface;

namespace {
constexpr double kPi = 3.14159265358979323846;
const Eigen::Vector3d kCentre(0.0123, -0.0371, 0.0217);  // off the lattice (SPEC §7)

std::unique_ptr<Surface> posed(std::unique_ptr<Surface> s) {
  s->set_pose(kCentre, Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix());
  return s;
}

struct Pipeline {
  VoxelSet voxels;
  SurfelSet surfels;
  SurfelMeasures mu;
  SurfaceOperator op;
};

// The reference computation's parameters: t = 0.03 h^(2/3), k = 6, II normals k_R = 1 (l = 1).
Pipeline run(const Surface& s, double h, bool exact = false, double c_t = 0.03) {
  Pipeline p;
  p.voxels = digitize(s, h);
  p.surfels = extract_surfels(p.voxels);
  p.mu = measures(p.surfels, exact ? exact_normals(s, p.surfels, 1.0) : ii_normals(p.voxels, p.surfels, {1.0, 1.0}));
  HeatLaplacianOptions o;
  o.c_t = c_t;
  p.op = heat_laplacian(p.surfels, p.mu, o);
  return p;
}

// max |L g - Delta_S g| / max |Delta_S g| for g = x^2 (relative to the centre), at the closest
// points (SPEC §7: Delta_S g = tr(Hess g) - <n, Hess g n> - 2 H <grad g, n>).
double x2_error(const Surface& s, const SurfaceOperator& op) {
  Eigen::VectorXd g(op.rows()), lap(op.rows());
  for (Eigen::Index i = 0; i < op.rows(); ++i) {
    const Eigen::Vector3d p = s.closest_point(op.positions.row(i).transpose()), q = p - kCentre, n = s.normal(p);
    g[i] = q.x() * q.x();
    lap[i] = 2 - 2 * n.x() * n.x() - 2 * s.mean_curvature(p) * 2 * q.x() * n.x();
  }
  return (op.L * g - lap).cwiseAbs().maxCoeff() / lap.cwiseAbs().maxCoeff();
}
}  // namespace

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
  EXPECT_THROW(make_surface("cube"), Error);
  EXPECT_THROW(make_surface("sphere:q=1"), Error);
  EXPECT_THROW(sphere.closest_point({NAN, 0, 0}), Error);
}

// Gauss digitization equals the inside test voxel by voxel; surfels are exactly the faces
// between a voxel inside and a 6-neighbour outside.
// Runs keep the digitization's memory with the surface: the unit sphere at h = 0.002 (5.2e8
// voxels, 8 bytes each as a bitmap would be 4 GB) in 16 MB, its voxel count within 1e-4 of
// the ball's volume / h^3 (the lattice-point error is O(h)).
TEST(Surface, FineDigitizationStaysSmall) {
  const double h = 0.002;
  const VoxelSet v = digitize(Sphere(), h);
  EXPECT_LT(v.memory_bytes(), 100u << 20);  // the issue asks well under 1 GB; measured 16.4 MB
  const double volume = 4.0 / 3.0 * 3.14159265358979323846 / (h * h * h);
  EXPECT_NEAR(static_cast<double>(v.voxel_count()), volume, 1e-4 * volume);
}

TEST(Surface, DigitizationAndSurfelsEqualBruteForce) {
  for (const char* name : {"sphere", "ellipsoid", "torus"}) {
    const auto s = posed(make_surface(name));
    const double h = 0.08;
    const VoxelSet v = digitize(*s, h);
    const auto box = s->bounding_box();
    std::int64_t expected = 0, mismatches = 0, faces = 0;
    auto in = [&](std::int64_t i, std::int64_t j, std::int64_t k) { return s->inside(Eigen::Vector3d(i * h, j * h, k * h)); };
    for (std::int64_t k = std::floor(box.min().z() / h) - 2; k <= std::ceil(box.max().z() / h) + 2; ++k)
      for (std::int64_t j = std::floor(box.min().y() / h) - 2; j <= std::ceil(box.max().y() / h) + 2; ++j)
        for (std::int64_t i = std::floor(box.min().x() / h) - 2; i <= std::ceil(box.max().x() / h) + 2; ++i) {
          const bool inside = in(i, j, k);
          expected += inside;
          mismatches += inside != v.contains(static_cast<int>(i), static_cast<int>(j), static_cast<int>(k));
          if (inside) faces += !in(i + 1, j, k) + !in(i - 1, j, k) + !in(i, j + 1, k) + !in(i, j - 1, k) + !in(i, j, k + 1) + !in(i, j, k - 1);
        }
    EXPECT_EQ(mismatches, 0) << name;
    EXPECT_EQ(v.voxel_count(), expected) << name;
    const SurfelSet f = extract_surfels(v);
    EXPECT_EQ(static_cast<std::int64_t>(f.size()), faces) << name;
    for (const Surfel& surfel : f.surfels) {
      Eigen::Vector3i out = surfel.voxel;
      out[surfel.axis] += surfel.sign;
      ASSERT_TRUE(v.contains(surfel.voxel.x(), surfel.voxel.y(), surfel.voxel.z()));
      ASSERT_FALSE(v.contains(out.x(), out.y(), out.z()));
    }
  }
  // Memory like the surface: the unit sphere at h = 0.002 (a billion voxels inside).
  const VoxelSet fine = digitize(Sphere(), 0.002);
  EXPECT_LT(fine.memory_bytes(), 100u << 20);
  EXPECT_NEAR(static_cast<double>(fine.voxel_count()) * 8e-9, 4 * kPi / 3, 1e-3);
}

// The operator's x^2 error on the unit sphere equals the independent NumPy implementation of
// SPEC §7 at the same h (same definitions: closest-point sampling, k = 6, t = 0.03 h^(2/3), II
// normals k_R = 1): 27.8%, 18.8%, 12.4% at h = 0.1, 0.07, 0.05 (issue 13). The tolerance, 0.1
// point, is the rounding of the quoted figures.
TEST(Surface, SphereErrorEqualsTheReferenceImplementation) {
  Sphere sphere;
  sphere.set_pose(kCentre, Eigen::Matrix3d::Identity());
  const std::vector<std::pair<double, double>> reference = {{0.1, 27.8}, {0.07, 18.8}, {0.05, 12.4}};
  for (const auto& [h, percent] : reference) {
    const Pipeline p = run(sphere, h);
    EXPECT_NEAR(100 * x2_error(sphere, p.op), percent, 0.1) << "h = " << h;
  }
  const Pipeline p = run(sphere, 0.025);
  EXPECT_EQ(p.op.rows(), 30150);  // DGtal's and the reference's N at h = 0.025
  EXPECT_NEAR(p.mu.total_area(), 4 * kPi, 2e-3 * 4 * kPi);  // sum mu -> area (6e-4 measured)
}

// Ellipsoid and torus: the error falls with h (slope ~1 in the reference: 29% -> 3.8%, 4.4%).
TEST(Surface, EllipsoidAndTorusConverge) {
  for (const char* name : {"ellipsoid", "torus"}) {
    const auto s = make_surface(name);
    s->set_pose(kCentre, Eigen::Matrix3d::Identity());
    const double coarse = x2_error(*s, run(*s, 0.1).op), fine = x2_error(*s, run(*s, 0.035).op);
    const double slope = std::log(coarse / fine) / std::log(0.1 / 0.035);
    EXPECT_GT(slope, 0.8) << name << ": " << coarse << " -> " << fine;
    EXPECT_LT(fine, 0.12) << name;
  }
}

// Structure on every reference surface: rows sum to 0, off-diagonals >= 0, A symmetric bit for
// bit, -A positive semidefinite, and equal to SPEC §7 evaluated over all pairs.
TEST(Surface, OperatorStructureAndBruteForce) {
  for (const char* name : {"sphere", "ellipsoid", "torus"}) {
    const auto s = posed(make_surface(name));
    const Pipeline p = run(*s, 0.15);
    const SurfaceOperator& op = p.op;
    const Eigen::Index n = op.rows();
    const Eigen::MatrixXd L(op.L), A(op.A);
    const double t = op.t, cut = 6 * std::sqrt(t);
    Eigen::MatrixXd brute = Eigen::MatrixXd::Zero(n, n);
    for (Eigen::Index i = 0; i < n; ++i)
      for (Eigen::Index j = 0; j < n; ++j) {
        const double d2 = (op.positions.row(i) - op.positions.row(j)).squaredNorm();
        if (i != j && d2 <= cut * cut) brute(i, j) = std::exp(-d2 / (4 * t)) * op.mass[j] / (4 * kPi * t * t);
      }
    brute.diagonal() = -brute.rowwise().sum();
    EXPECT_LE((L - brute).cwiseAbs().maxCoeff(), 1e-12 * L.cwiseAbs().maxCoeff()) << name;
    EXPECT_EQ((A - A.transpose()).cwiseAbs().maxCoeff(), 0.0) << name;
    for (Eigen::Index i = 0; i < n; ++i) EXPECT_LE(std::abs(L.row(i).sum()), 1e-12 * std::abs(L(i, i))) << name;
    EXPECT_GE((L - Eigen::MatrixXd(L.diagonal().asDiagonal())).minCoeff(), 0.0) << name;
    const Eigen::VectorXd eig = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(-A).eigenvalues();
    EXPECT_GE(eig.minCoeff(), -1e-10 * eig.maxCoeff()) << name;
  }
}

TEST(Surface, BitwiseIdenticalForOneAndTwoThreads) {
  const auto s = posed(make_surface("torus"));
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const Pipeline one = run(*s, 0.05);
  omp_set_num_threads(2);
  const Pipeline two = run(*s, 0.05);
  omp_set_num_threads(threads);
  ASSERT_EQ(one.op.L.nonZeros(), two.op.L.nonZeros());
  EXPECT_EQ(std::memcmp(one.mu.mu.data(), two.mu.mu.data(), sizeof(double) * one.mu.mu.size()), 0);
  EXPECT_EQ(std::memcmp(one.op.L.valuePtr(), two.op.L.valuePtr(), sizeof(double) * one.op.L.nonZeros()), 0);
  EXPECT_EQ(std::memcmp(one.op.L.innerIndexPtr(), two.op.L.innerIndexPtr(), sizeof(int) * one.op.L.nonZeros()), 0);
  // The spectrum by LOBPCG on products too (its block products and algebra run in fixed chunks),
  // on the sphere (the torus at h = 0.05 has surfels of zero area: M is not definite).
  const Pipeline sphere = run(Sphere(), 0.1, true, 0.1);
  SpectrumOptions o;
  o.count = 8, o.method = SpectrumMethod::Products;
  omp_set_num_threads(1);
  const Spectrum s1 = smallest_eigenpairs(sphere.op.A, sphere.op.mass, o);
  omp_set_num_threads(2);
  const Spectrum s2 = smallest_eigenpairs(sphere.op.A, sphere.op.mass, o);
  omp_set_num_threads(threads);
  EXPECT_EQ(std::memcmp(s1.eigenvalues.data(), s2.eigenvalues.data(), sizeof(double) * 8), 0);
  EXPECT_EQ(std::memcmp(s1.eigenvectors.data(), s2.eigenvectors.data(), sizeof(double) * s1.eigenvectors.size()), 0);
}

// The sphere's spectrum through the 2D solvers (A, mass), and its heat flow. Reference
// (issue 13): at h = 0.05, exact normals, t = 0.1 h^(2/3), l = 1..3 raw within 7.3% of l(l+1),
// within 0.8% after lambda -> -ln(1 - lambda t) / t. Here at h = 0.1 (the fine step is the next
// test), where we measure raw 12.1% and corrected 1.3%: asserted within 15% and 2%, the
// 3 + 5 + 7 copies within 2% of each other. Both solvers (the factorization and LOBPCG on
// products, the surfaces' method) give the same pairs.
TEST(Surface, SphereSpectrumAndHeatFlow) {
  Sphere sphere;
  sphere.set_pose(kCentre, Eigen::Matrix3d::Identity());
  const Pipeline p = run(sphere, 0.1, true, 0.1);
  SpectrumOptions factorized, products;
  factorized.count = products.count = 16;
  factorized.method = SpectrumMethod::Factorization, products.method = SpectrumMethod::Products;
  const Spectrum s = smallest_eigenpairs(p.op.A, p.op.mass, factorized);
  const Eigen::VectorXd mu = laplace_beltrami_eigenvalues(s.eigenvalues, p.op.t);
  EXPECT_LE(std::abs(s.eigenvalues[0]), 1e-8);
  // LOBPCG's residuals are within 1e-10 of the spectrum's bound c <= 2 / t (about 120 here), so
  // its eigenvalues agree to c 1e-10 (a residual bound) with slack for the clusters: 1e-7.
  const Spectrum q = smallest_eigenpairs(p.op.A, p.op.mass, products);
  EXPECT_LT((q.eigenvalues - s.eigenvalues).cwiseAbs().maxCoeff(), 1e-7);
  EXPECT_LT(q.iterations, 40);
  // The same invariant subspaces: the projector of each cluster agrees (eigenvectors within a
  // cluster are any M-orthonormal basis of it).
  for (const auto& [first, size] : {std::pair{1, 3}, std::pair{4, 5}, std::pair{9, 7}}) {
    const Eigen::MatrixXd a = s.eigenvectors.middleCols(first, size), b = q.eigenvectors.middleCols(first, size);
    const Eigen::MatrixXd overlap = a.transpose() * p.op.mass.asDiagonal() * b;  // orthogonal when equal spans
    EXPECT_NEAR((overlap.transpose() * overlap).trace(), size, 1e-6) << "cluster at " << first;
  }
  int k = 1;
  for (int l = 1; l <= 3; ++l) {
    const double exact = l * (l + 1.0);
    double lo = 1e300, hi = 0;
    for (int m = 0; m < 2 * l + 1; ++m, ++k) {
      EXPECT_NEAR(s.eigenvalues[k], exact, 0.15 * exact) << "l = " << l;
      EXPECT_NEAR(mu[k], exact, 0.02 * exact) << "l = " << l;
      lo = std::min(lo, mu[k]), hi = std::max(hi, mu[k]);
    }
    EXPECT_LT((hi - lo) / exact, 0.02) << "l = " << l;  // the 2l + 1 copies stay together
  }
  // Heat flow: the first mode (x, eigenvalue 2) decays like exp(-2 tau); the operator's own
  // decay is exp(-lambda_1 tau) with lambda_1 = (1 - e^(-2t))/t, so compare with the estimate.
  Eigen::VectorXd u0(p.op.rows());
  for (Eigen::Index i = 0; i < u0.size(); ++i) u0[i] = sphere.closest_point(p.op.positions.row(i).transpose()).x() - kCentre.x();
  const double tau = 0.2;
  const Eigen::VectorXd u = HeatFlow(p.op.A, p.op.mass, tau / 40, TimeScheme::CrankNicolson).advance(u0, 40);
  const double amplitude = u.dot(p.op.mass.cwiseProduct(u0)) / u0.dot(p.op.mass.cwiseProduct(u0));
  EXPECT_NEAR(amplitude, std::exp(-2 * tau), 0.01 * std::exp(-2 * tau));
}

// Issue 25, item 8: on surfaces the factors of M - theta dt A fill in (1.96 GB at 20,036
// surfels), so the flow from a surface operator solves each step by conjugate gradients. On the
// sphere at h = 0.1, 40 Crank-Nicolson steps: the same state as with the factorization to 1e-10
// of its size (the CG residual is 1e-12 relative per step; 40 steps of a contraction add at most
// 40 of those), the total heat kept to 1e-12, a few iterations per step (M dominates: dt / t is
// small), and the same bits for 1 and 2 threads (rows in parallel, dot products in order).
TEST(Surface, HeatFlowOnSurfacesSolvesByConjugateGradients) {
  Sphere sphere;
  sphere.set_pose(kCentre, Eigen::Matrix3d::Identity());
  const Pipeline p = run(sphere, 0.1, true, 0.1);
  Eigen::VectorXd u0(p.op.rows());
  for (Eigen::Index i = 0; i < u0.size(); ++i) u0[i] = std::exp(-4 * (p.op.positions.row(i).transpose() - kCentre - Eigen::Vector3d(1, 0, 0)).squaredNorm());
  const double dt = 0.2 / 40;
  const HeatFlow by_cg(p.op, dt);
  EXPECT_EQ(by_cg.solver(), HeatSolver::ConjugateGradient);
  const HeatFlow factorized(p.op, dt, TimeScheme::CrankNicolson, HeatSolver::Factorization);
  EXPECT_EQ(factorized.solver(), HeatSolver::Factorization);
  EXPECT_EQ(HeatFlow(p.op.A, p.op.mass, dt).solver(), HeatSolver::Factorization);  // a bare pair: no dimension known
  const Eigen::VectorXd u = by_cg.advance(u0, 40), reference = factorized.advance(u0, 40);
  EXPECT_LT((u - reference).cwiseAbs().maxCoeff(), 1e-10 * reference.cwiseAbs().maxCoeff());
  EXPECT_NEAR(u.dot(p.op.mass), u0.dot(p.op.mass), 1e-12 * u0.dot(p.op.mass));
  by_cg.step(u0);
  EXPECT_GT(by_cg.last_iterations(), 0);
  EXPECT_LT(by_cg.last_iterations(), 40);
  EXPECT_EQ(on_threads(1, [&] { return by_cg.advance(u0, 5); }), on_threads(2, [&] { return by_cg.advance(u0, 5); }));
}

// Fairing of a digital sphere whose surfel centres carry noise: the 3D positions through the
// same smoothing core as the 2D contours. Roundness (std / mean of the distance to the
// centroid): 0.0234 for the digital staircase, 0.0295 with the noise (uniform, +-0.03 per
// coordinate), 0.0043 after fairing for tau = 5 t (the shortest scales damped like exp(-5)).
// Asserted: below 0.3 of the noisy and of the digital one, the RMS radius kept to 1e-12.
TEST(Surface, SmoothingFairsANoisySphere) {
  const Pipeline p = run(Sphere(), 0.1, true, 0.1);
  SurfaceOperator noisy = p.op;
  std::mt19937 random(7);
  std::uniform_real_distribution<double> noise(-0.03, 0.03);
  for (Eigen::Index k = 0; k < noisy.positions.size(); ++k) noisy.positions.data()[k] += noise(random);
  SurfaceSmoothingOptions o;
  o.tau = 5 * noisy.t;
  const Eigen::MatrixX3d faired = smooth_positions(noisy, o);
  const double before = roundness(noisy.positions, noisy.mass), after = roundness(faired, noisy.mass);
  std::printf("roundness: digital %.4f, noisy %.4f, faired %.4f\n", roundness(p.op.positions, p.op.mass), before, after);
  EXPECT_LT(after, 0.3 * before);
  EXPECT_LT(after, 0.3 * roundness(p.op.positions, p.op.mass));
  auto rms = [&](const Eigen::MatrixX3d& x) {
    const Eigen::RowVector3d c = (noisy.mass.transpose() * x) / noisy.mass.sum();
    return std::sqrt(noisy.mass.dot((x.rowwise() - c).rowwise().squaredNorm()) / noisy.mass.sum());
  };
  EXPECT_NEAR(rms(faired), rms(noisy.positions), 1e-12 * rms(noisy.positions));
  o.preserve_size = false;  // without the rescaling the sphere shrinks, like exp(-2 tau) at most
  EXPECT_LT(rms(smooth_positions(noisy, o)), rms(noisy.positions));
  EXPECT_THROW(smooth_positions(noisy, {0.0}), Error);
}

// Issue 13's must-show: the sphere at h = 0.02 with the defaults (II normals, c_t = 0.1, the
// measured length scale), N = 46,950, through LOBPCG on products (about 20 s and 4.7 GB; the
// factorization would not fit). Measured: l = 1..3 within 0.57% of l(l+1) after the bias
// correction, clusters split by 0.19% (l = 2) and 0.10% (l = 3). Asserted: 1% and 1%, the
// issue's figures. Left out of the sanitizer run (scripts/sanitize.sh) for its size.
TEST(Surface, SphereSpectrumAtFineStep) {
  Sphere sphere;
  sphere.set_pose(kCentre, Eigen::Matrix3d::Identity());
  const VoxelSet voxels = digitize(sphere, 0.02);
  const SurfelSet surfels = extract_surfels(voxels);
  const SurfelMeasures mu = measures(surfels, ii_normals(voxels, surfels));
  const SurfaceOperator op = heat_laplacian(surfels, mu);
  SpectrumOptions o;
  o.count = 17, o.method = SpectrumMethod::Products;
  const Spectrum s = smallest_eigenpairs(op.A, op.mass, o);
  const Eigen::VectorXd lb = laplace_beltrami_eigenvalues(s.eigenvalues, op.t);
  int k = 1;
  for (int l = 1; l <= 3; ++l) {
    const double exact = l * (l + 1.0);
    double lo = 1e300, hi = 0;
    for (int m = 0; m < 2 * l + 1; ++m, ++k) {
      EXPECT_NEAR(lb[k], exact, 0.01 * exact) << "l = " << l << ", k = " << k;
      lo = std::min(lo, lb[k]), hi = std::max(hi, lb[k]);
    }
    EXPECT_LT((hi - lo) / exact, 0.01) << "l = " << l;
  }
  EXPECT_GT(lb[16], 19.0);  // the 17th is l = 4 (20): the three clusters are whole
}

// The surfels as a quad mesh: corners shared, so the Euler characteristic V - E + F (E = 2F
// for a closed quad mesh) is the surface's: 2 for the sphere and the ellipsoid, 0 for the torus.
// The file's header and size follow the PLY layout. (The torus is taken at h = 0.07: at 0.1 and
// 0.05 its digitization has a voxel meeting another by an edge only, where the quad mesh pinches
// and V - F is -1: a digital, not a continuous, surface.)
TEST(Surface, PlyQuadMeshHasTheTopologyOfTheSurface) {
  const std::string dir = ::testing::TempDir();
  for (const auto& [name, euler, h] : {std::tuple<const char*, long, double>{"sphere", 2, 0.1}, {"ellipsoid", 2, 0.1}, {"torus", 0, 0.07}}) {
    const auto s = posed(make_surface(name));
    const SurfelSet f = extract_surfels(digitize(*s, h));
    const Eigen::VectorXd mu = Eigen::VectorXd::Constant(static_cast<Eigen::Index>(f.size()), 0.01);
    const std::string path = dir + "/" + name + ".ply";
    const PlyMeshSize size = save_ply(f, {{"mu", mu}, {"phi_1", mu}}, path);
    EXPECT_EQ(size.faces, f.size());
    EXPECT_EQ(static_cast<long>(size.vertices) - static_cast<long>(size.faces), euler) << name;
    std::ifstream in(path, std::ios::binary);
    std::string header, line;
    while (std::getline(in, line) && line != "end_header") header += line + "\n";
    EXPECT_NE(header.find("element face " + std::to_string(f.size())), std::string::npos);
    EXPECT_NE(header.find("property float phi_1"), std::string::npos);
    in.seekg(0, std::ios::end);
    const auto bytes = static_cast<std::size_t>(in.tellg()) - header.size() - std::string("end_header\n").size();
    EXPECT_EQ(bytes, 12 * size.vertices + (1 + 16 + 8) * size.faces);
  }
  const SurfelSet f = extract_surfels(digitize(Sphere(), 0.5));
  EXPECT_THROW(save_ply(f, {{"bad name", Eigen::VectorXd::Zero(static_cast<Eigen::Index>(f.size()))}}, dir + "/x.ply"), Error);
  EXPECT_THROW(save_ply(f, {{"mu", Eigen::VectorXd::Zero(3)}}, dir + "/x.ply"), Error);
}

// --- Volumes in (.npy) ---------------------------------------------------------------------------

namespace {
std::string npy(const std::string& descr, bool fortran, const std::vector<std::size_t>& shape, const std::string& data) {
  std::string dims;
  for (std::size_t d : shape) dims += std::to_string(d) + ",";
  std::string dict = "{'descr': '" + descr + "', 'fortran_order': " + (fortran ? "True" : "False") + ", 'shape': (" + dims + "), }";
  dict.append((64 - (10 + dict.size() + 1) % 64) % 64, ' ');
  dict += '\n';
  return std::string("\x93NUMPY\x01\x00", 8) + static_cast<char>(dict.size() & 0xff) + static_cast<char>(dict.size() >> 8) + dict + data;
}
std::string write(const std::string& name, const std::string& bytes) {
  const std::string path = ::testing::TempDir() + "/" + name;
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}
}  // namespace

// A digitized sphere written as a (plane, row, column) uint8 array, in C and in Fortran order,
// and as labels in a uint16 segmentation: read back, the same voxels (shifted to the array's
// corner) and the same surfels.
TEST(Surface, NpyVolumesReadBackTheVoxels) {
  const double h = 0.1;
  const VoxelSet sphere = digitize(Sphere(), h);
  const int n = 24, shift = 12;  // the sphere's voxels -11..11 land in 1..23
  std::string c_order(n * n * n, '\0'), f_order(n * n * n, '\0'), labels(2 * n * n * n, '\0');
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b)
      for (int c = 0; c < n; ++c) {
        const bool in = sphere.contains(c - shift, b - shift, a - shift);  // element [a, b, c] is voxel (c, b, a)
        c_order[(a * n + b) * n + c] = in;
        f_order[a + n * (b + n * c)] = in;
        labels[2 * ((a * n + b) * n + c)] = in ? 3 : (c < 2 ? 7 : 0);  // the sphere has label 3, a slab label 7
      }
  const SurfelSet expected = extract_surfels(sphere);
  for (const auto& [name, bytes, options] :
       {std::tuple{"c.npy", npy("|u1", false, {24, 24, 24}, c_order), VolumeOptions{h}},
        std::tuple{"f.npy", npy("|b1", true, {24, 24, 24}, f_order), VolumeOptions{h}},
        std::tuple{"labels.npy", npy("<u2", false, {24, 24, 24}, labels), VolumeOptions{h, 3}}}) {
    const VoxelSet v = read_npy_volume(write(name, bytes), options);
    EXPECT_EQ(v.voxel_count(), sphere.voxel_count()) << name;
    EXPECT_TRUE(v.contains(shift, shift, shift)) << name;
    EXPECT_EQ(extract_surfels(v).size(), expected.size()) << name;
  }
  const VoxelSet slab = read_npy_volume(write("labels.npy", npy("<u2", false, {24, 24, 24}, labels)), VolumeOptions{0, 7});
  EXPECT_EQ(slab.voxel_count(), 2 * n * n - 0);  // c = 0, 1: every (a, b) outside the sphere
  EXPECT_DOUBLE_EQ(slab.h(), 1.0);  // voxel units by default: padding changes nothing
}

// A one-voxel-thick slab stored across the rows (n x n x 1 in C order: every row one voxel) and
// along them (1 x n x n): the same voxels and surfels, and storage bounded by the grid's voxels
// (8 bytes per row and per run), not by a list per row (24+ bytes each: 2 GB at 8000 x 8000, issue 25).
TEST(Surface, VoxelStorageIsBoundedByTheVoxelsWhateverTheShape) {
  const int n = 400;
  std::string across(n * n, '\0');
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) across[a * n + b] = (a - 200) * (a - 200) + (b - 200) * (b - 200) < 150 * 150;
  const VoxelSet thin = read_npy_volume(write("across.npy", npy("|u1", false, {n, n, 1}, across)));
  const VoxelSet wide = read_npy_volume(write("along.npy", npy("|u1", false, {1, n, n}, across)));
  const VoxelSet from_mask = VoxelSet::from_mask(1.0, reinterpret_cast<const std::uint8_t*>(across.data()), 1, n, n, 1, 1, n);
  EXPECT_EQ(thin.voxel_count(), wide.voxel_count());
  EXPECT_EQ(from_mask.voxel_count(), wide.voxel_count());
  EXPECT_EQ(extract_surfels(thin).size(), extract_surfels(wide).size());
  const double grid_voxels = static_cast<double>(n) * n;
  for (const VoxelSet* v : {&thin, &wide, &from_mask}) EXPECT_LE(static_cast<double>(v->memory_bytes()), 16 * grid_voxels + 64);
  EXPECT_LT(static_cast<double>(wide.memory_bytes()), 16.0 * n + 8.0 * 2 * n + 64);  // n rows, one or two runs each

  // Compressed rows are checked, not trusted.
  auto fragment = [](std::vector<std::int64_t> offsets, std::vector<digilap::Run> runs) {
    return error_of([&] { VoxelSet::from_compressed_rows(1.0, 0, 0, 2, 1, offsets, runs); });
  };
  EXPECT_NE(fragment({0, 1}, {{0, 1}}).find("nj x nk + 1"), std::string::npos);
  EXPECT_NE(fragment({0, 1, 2}, {{0, 1}}).find("nj x nk + 1"), std::string::npos);
  EXPECT_NE(fragment({0, 2, 1}, {{0, 1}}).find("must not decrease"), std::string::npos);
  EXPECT_NE(fragment({0, 1, 0}, {}).find("must not decrease"), std::string::npos);
  EXPECT_NE(fragment({0, 2, 2}, {{0, 3}, {2, 4}}).find("sorted and disjoint"), std::string::npos);
  EXPECT_NE(fragment({0, 1, 1}, {{2, 2}}).find("non-empty"), std::string::npos);
  EXPECT_EQ(VoxelSet::from_compressed_rows(1.0, 0, 0, 2, 1, {0, 2, 3}, {{0, 1}, {2, 4}, {5, 6}}).voxel_count(), 4);
}

// The peak of reading such a slab, not only what is kept: 3000 x 3000 x 1, 9e6 rows of one
// voxel, read in a child process whose peak resident memory the kernel reports. Storage is
// 16 bytes per voxel (144 MB) plus the file (9 MB); one list per row peaked at 540 MB (measured).
TEST(Surface, ReadingAThinSlabPeaksNearItsStorage) {
  const int n = 3000;
  const std::string path = write("slab.npy", npy("|u1", false, {n, n, 1}, std::string(static_cast<std::size_t>(n) * n, '\1')));
  rusage self{};
  getrusage(RUSAGE_SELF, &self);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) _exit(read_npy_volume(path).voxel_count() == std::int64_t(n) * n ? 0 : 1);  // serial reader: no OpenMP after fork
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  rusage children{};
  getrusage(RUSAGE_CHILDREN, &children);
  const double peak_mb = (static_cast<double>(children.ru_maxrss) - static_cast<double>(self.ru_maxrss)) / 1024;
  EXPECT_LT(peak_mb, 250) << "reading 9e6 one-voxel rows peaked " << peak_mb << " MB above the parent";
}

// Every malformed or unsupported file is refused with the file and the reason.
TEST(Surface, BadNpyVolumesAreRefused) {
  const std::string cube(8, '\1');
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "the file is empty"},
      {"GIF89a....", "not a .npy file"},
      {npy("|u1", false, {2, 2, 2}, "\1\1\1"), "truncated: the data holds 3 of 8 bytes"},
      {npy("|u1", false, {4, 2}, cube), "a volume needs 3 dimensions, got 2"},
      {npy("<c16", false, {1, 1, 1}, std::string(16, '\0')), "dtype '<c16' is not supported"},
      {npy("<f8", false, {1, 1, 1}, std::string("\0\0\0\0\0\0\xf8\x7f", 8)), "voxel (0, 0, 0) is NaN"},
      {std::string("\x93NUMPY\x01\x00\x40\x00", 10) + "{'descr': '|u1', 'fortran_order': False, 'shape': (-2, 2, 2), }   \n",
       "the dimension '-' is not a size"},
      {npy("|u1", false, {2, 0, 2}, ""), "the volume is empty"},
      {npy("|u1", false, {2, 2, 2}, std::string(8, '\0')), "no voxel reaches the threshold"},
      {npy("|u1", false, {100000, 100000, 100000}, ""), "above the limit"},
      {npy("|u1", false, {100000000000, 100000000000, 100000000000}, ""), "its 1e+33 voxels are above the limit"},
      {std::string("\x93NUMPY\x01\x00\xff\xff", 10), "truncated header"},
      {std::string("\x93NUMPY\x01\x00\x10\x00", 10) + "{'descr': '|u1'}", "no 'fortran_order'"},
  };
  for (const auto& [bytes, fragment] : cases) {
    const std::string path = write("bad.npy", bytes);
    const std::string message = error_of([&] { read_npy_volume(path); });
    EXPECT_NE(message.find(fragment), std::string::npos) << "message: " << message;
    EXPECT_NE(message.find("bad.npy"), std::string::npos) << message;
  }
  EXPECT_NE(error_of([] { read_npy_volume("/nonexistent/volume.npy"); }).find("cannot open"), std::string::npos);
}

// Connected surfaces: one per surface of the set; voxels meeting by an edge or a corner only
// are separate objects (6-connected), a hole through an object (the torus) is one surface.
TEST(Surface, ConnectedSurfacesAndFilters) {
  using V = std::vector<Eigen::Vector3i>;
  auto components = [](const V& voxels) {
    const VoxelSet set = VoxelSet::from_voxels(1.0, voxels);
    return connected_surfaces(set, extract_surfels(set)).sizes;
  };
  EXPECT_EQ(components(V{{0, 0, 0}}), (std::vector<std::size_t>{6}));
  EXPECT_EQ(components(V{{0, 0, 0}, {1, 0, 0}}), (std::vector<std::size_t>{10}));       // face-adjacent: one box
  EXPECT_EQ(components(V{{0, 0, 0}, {1, 1, 0}}), (std::vector<std::size_t>{6, 6}));     // by an edge: apart
  EXPECT_EQ(components(V{{0, 0, 0}, {1, 1, 1}}), (std::vector<std::size_t>{6, 6}));     // by a corner: apart
  V shell;  // a hollow 5^3 cube: an outer and an inner surface
  for (int k = 0; k < 5; ++k)
    for (int j = 0; j < 5; ++j)
      for (int i = 0; i < 5; ++i)
        if (i % 4 == 0 || j % 4 == 0 || k % 4 == 0) shell.emplace_back(i, j, k);
  EXPECT_EQ(components(shell), (std::vector<std::size_t>{150, 54}));
  // Two spheres and a speck: filters by size and largest.
  Sphere big, small(0.5);
  big.set_pose(kCentre, Eigen::Matrix3d::Identity());
  small.set_pose(kCentre + Eigen::Vector3d(3, 0, 0), Eigen::Matrix3d::Identity());
  V voxels;
  for (const Surface* s : {static_cast<const Surface*>(&big), static_cast<const Surface*>(&small)}) {
    const VoxelSet v = digitize(*s, 0.1);
    for (std::int32_t k = v.k_begin(); k < v.k_end(); ++k)
      for (std::int32_t j = v.j_begin(); j < v.j_end(); ++j)
        for (const digilap::Run* r = v.row_begin(j, k); r != v.row_end(j, k); ++r)
          for (std::int32_t i = r->begin; i < r->end; ++i) voxels.emplace_back(i, j, k);
  }
  voxels.emplace_back(0, 40, 0);
  const VoxelSet set = VoxelSet::from_voxels(0.1, voxels);
  const SurfelSet all = extract_surfels(set);
  const std::vector<std::size_t> sizes = connected_surfaces(set, all).sizes;
  ASSERT_EQ(sizes.size(), 3u);
  EXPECT_EQ(filter_surfels(set, all, {7, false}).dropped, 1u);  // the speck's 6 surfels
  const FilteredSurfels largest = filter_surfels(set, all, {0, true});
  EXPECT_EQ(largest.dropped, 2u);
  EXPECT_EQ(largest.surfels.size(), extract_surfels(digitize(big, 0.1)).size());
  EXPECT_EQ(connected_surfaces(digitize(*posed(make_surface("torus")), 0.07), extract_surfels(digitize(*posed(make_surface("torus")), 0.07))).sizes.size(), 1u);
}

// --- Volumes in (NIfTI) --------------------------------------------------------------------------

namespace {
// A NIfTI file written here field by field from the standard's header structs (not through
// nifticlib, which reads it back): version 1 or 2, gzipped when the name ends in .gz.
struct NiftiSample {
  int version = 1;
  std::int64_t dim[8] = {3, 1, 1, 1, 1, 1, 1, 1};
  int datatype = DT_UINT8, bitpix = 8;
  double spacing[3] = {1, 1, 1};
  double slope = 0, inter = 0;
  const char* magic = nullptr;  // a wrong magic on purpose
  std::string data;
};
std::string nifti_bytes(const NiftiSample& s) {
  std::string header;
  if (s.version == 1) {
    nifti_1_header h{};
    h.sizeof_hdr = 348;
    for (int d = 0; d < 8; ++d) h.dim[d] = static_cast<short>(s.dim[d]);
    h.datatype = static_cast<short>(s.datatype), h.bitpix = static_cast<short>(s.bitpix);
    h.pixdim[0] = 1;
    for (int d = 0; d < 3; ++d) h.pixdim[d + 1] = static_cast<float>(s.spacing[d]);
    h.vox_offset = 352, h.scl_slope = static_cast<float>(s.slope), h.scl_inter = static_cast<float>(s.inter);
    h.xyzt_units = NIFTI_UNITS_MM;
    std::memcpy(h.magic, s.magic ? s.magic : "n+1", 4);
    header.assign(reinterpret_cast<const char*>(&h), sizeof h);
    header.append(4, '\0');  // no extensions
  } else {
    nifti_2_header h{};
    h.sizeof_hdr = 540;
    std::memcpy(h.magic, "n+2\0\r\n\032\n", 8);
    for (int d = 0; d < 8; ++d) h.dim[d] = s.dim[d];
    h.datatype = static_cast<short>(s.datatype), h.bitpix = static_cast<short>(s.bitpix);
    h.pixdim[0] = 1;
    for (int d = 0; d < 3; ++d) h.pixdim[d + 1] = s.spacing[d];
    h.vox_offset = 544, h.scl_slope = s.slope, h.scl_inter = s.inter;
    h.xyzt_units = NIFTI_UNITS_MM;
    header.assign(reinterpret_cast<const char*>(&h), sizeof h);
    header.append(4, '\0');
  }
  return header + s.data;
}
std::string write_nifti(const std::string& name, const std::string& bytes) {
  const std::string path = ::testing::TempDir() + "/" + name;
  if (name.size() > 3 && name.compare(name.size() - 3, 3, ".gz") == 0) {
    gzFile f = gzopen(path.c_str(), "wb");
    gzwrite(f, bytes.data(), static_cast<unsigned>(bytes.size()));
    gzclose(f);
  } else {
    std::ofstream(path, std::ios::binary) << bytes;
  }
  return path;
}
template <class T>
std::string raw(const std::vector<T>& values) {
  return std::string(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
}
}  // namespace

// A digitized sphere written as NIfTI-1 uint8 (.nii), NIfTI-1 int16 labels (.nii.gz), NIfTI-2
// float32 (.nii) and scaled uint8 (stored 1, slope 2, inter 1: value 3): read back, the same
// voxels at the file's index and the same surfels; h is the file's spacing unless given.
TEST(Surface, NiftiVolumesReadBackTheVoxels) {
  const VoxelSet sphere = digitize(Sphere(), 0.1);
  const int n = 24, shift = 12;
  std::vector<std::uint8_t> mask(n * n * n);
  std::vector<std::int16_t> labels(n * n * n);
  std::vector<float> levels(n * n * n);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const bool in = sphere.contains(i - shift, j - shift, k - shift);
        const std::size_t at = static_cast<std::size_t>((k * n + j) * n + i);  // x fastest
        mask[at] = in;
        labels[at] = in ? 3 : (i < 2 ? -7 : 0);
        levels[at] = in ? 0.75f : 0.25f;
      }
  auto sample = [&](int version, int datatype, int bitpix, std::string data, double spacing) {
    NiftiSample s;
    s.version = version, s.datatype = datatype, s.bitpix = bitpix, s.data = std::move(data);
    s.dim[1] = s.dim[2] = s.dim[3] = n;
    s.spacing[0] = s.spacing[1] = s.spacing[2] = spacing;
    return s;
  };
  NiftiSample scaled = sample(1, DT_UINT8, 8, raw(mask), 0.1);
  scaled.slope = 2, scaled.inter = 1;
  VolumeOptions label3;
  label3.label = 3;
  VolumeOptions half;
  half.threshold = 0.5;
  const SurfelSet expected = extract_surfels(sphere);
  for (const auto& [name, s, options] :
       {std::tuple{"mask.nii", sample(1, DT_UINT8, 8, raw(mask), 0.1), VolumeOptions{}},
        std::tuple{"labels.nii.gz", sample(1, DT_INT16, 16, raw(labels), 0.1), label3},
        std::tuple{"levels.nii", sample(2, DT_FLOAT32, 32, raw(levels), 0.1), half},
        std::tuple{"scaled.nii", scaled, label3}}) {
    const VoxelSet v = read_volume(write_nifti(name, nifti_bytes(s)), options);
    EXPECT_EQ(v.voxel_count(), sphere.voxel_count()) << name;
    EXPECT_TRUE(v.contains(shift, shift, shift)) << name;
    EXPECT_FALSE(v.contains(0, 0, 0)) << name;
    EXPECT_EQ(extract_surfels(v).size(), expected.size()) << name;
    EXPECT_NEAR(v.h(), 0.1, 1e-7) << name;  // NIfTI-1 stores the spacing as float
  }
  VolumeOptions slab;
  slab.label = 0, slab.h = 0.5;  // background label 0: everything but the sphere and the slab
  const VoxelSet rest = read_volume(write_nifti("labels.nii.gz", nifti_bytes(sample(1, DT_INT16, 16, raw(labels), 0.1))), slab);
  EXPECT_EQ(rest.voxel_count(), n * n * n - sphere.voxel_count() - 2 * n * n);
  EXPECT_EQ(rest.h(), 0.5);
  // No spacing in the file (0): nifticlib reads it as 1, so h is one voxel unit.
  EXPECT_DOUBLE_EQ(read_volume(write_nifti("nospacing.nii", nifti_bytes(sample(1, DT_UINT8, 8, raw(mask), 0)))).h(), 1.0);
}

// Every malformed, unsupported or anisotropic file is refused with the file and the reason.
TEST(Surface, BadNiftiVolumesAreRefused) {
  auto cube = [](int n, std::string data = "") {
    NiftiSample s;
    s.dim[1] = s.dim[2] = s.dim[3] = n;
    s.data = data.empty() ? std::string(static_cast<std::size_t>(n) * n * n, '\1') : data;
    return s;
  };
  NiftiSample anisotropic = cube(4);
  anisotropic.spacing[2] = 2.5;
  NiftiSample series = cube(2, std::string(24, '\1'));
  series.dim[0] = 4, series.dim[4] = 3;
  NiftiSample complex_type = cube(2, std::string(64, '\1'));
  complex_type.datatype = DT_COMPLEX64, complex_type.bitpix = 64;
  NiftiSample pair = cube(2);
  pair.magic = "ni1";
  NiftiSample huge = cube(2);
  huge.version = 2, huge.dim[1] = huge.dim[2] = huge.dim[3] = 5000;
  NiftiSample dark = cube(2, std::string(8, '\0'));
  NiftiSample zero_dim = cube(2);
  zero_dim.dim[2] = 0;
  NiftiSample no_dims = cube(2);
  no_dims.version = 2, no_dims.dim[0] = 0;
  // NIfTI-2 spacings are doubles: 1e200 would make every area inf, 1e-200 every area 0 (fuzzer).
  NiftiSample vast = cube(2), tiny = cube(2);
  vast.version = tiny.version = 2;
  for (int d = 0; d < 3; ++d) vast.spacing[d] = 1e200, tiny.spacing[d] = 1e-200;
  // A 2-D image is refused as the .npy reader refuses it (it was read as a one-voxel slab).
  NiftiSample flat = cube(4, std::string(16, '\1'));
  flat.dim[0] = 2, flat.dim[3] = 1;
  // NaN compares false with every threshold: it was read as background, a hole in the object.
  std::vector<float> levels(8, 1.0f);
  levels[5] = std::numeric_limits<float>::quiet_NaN();
  NiftiSample with_nan = cube(2, raw(levels));
  with_nan.datatype = DT_FLOAT32, with_nan.bitpix = 32;
  const std::string good = nifti_bytes(cube(4));
  const std::vector<std::tuple<std::string, std::string, std::string>> cases = {
      {"bad.nii", nifti_bytes(vast), "the voxel spacing 1e+200 is outside [1e-30, 1e+30]"},
      {"bad.nii", nifti_bytes(tiny), "the voxel spacing 1e-200 is outside [1e-30, 1e+30]"},
      {"bad.nii", "", "the file is empty"},
      {"bad.nii", "GIF89a....", "truncated header (10 bytes"},
      {"bad.nii", std::string(400, 'x'), "not a NIfTI file (sizeof_hdr is"},
      {"bad.nii", good.substr(0, 200), "truncated header (200 bytes"},
      {"bad.nii", good.substr(0, 352 + 30), "truncated: the data needs 64 bytes from byte 352"},
      {"bad.nii.gz", good.substr(0, 352 + 30), "truncated or unreadable voxel data"},
      {"bad.nii", nifti_bytes(anisotropic), "anisotropic voxel spacing 1 x 1 x 2.5 mm"},
      {"bad.nii", nifti_bytes(series), "holds 3 volumes"},
      {"bad.nii", nifti_bytes(complex_type), "data type COMPLEX64 (code 32) is not supported"},
      {"bad.nii", nifti_bytes(pair), ".hdr/.img pair"},
      {"bad.nii", nifti_bytes(huge), "125000000000 voxels are above the limit"},
      {"bad.nii", nifti_bytes(dark), "no voxel reaches the threshold"},
      {"bad.nii.gz", std::string(400, 'x'), "not a NIfTI file"},
      {"bad.nii", nifti_bytes(zero_dim), "dimension 2 is 0"},
      {"bad.nii.gz", nifti_bytes(no_dims), "dim[0] is 0"},
      {"bad.nii", nifti_bytes(flat), "it is a 2-D image; a volume needs 3 dimensions"},
      {"bad.nii", nifti_bytes(with_nan), "voxel (1, 0, 1) is NaN"},
  };
  for (const auto& [name, bytes, fragment] : cases) {
    const std::string path = write_nifti(name, bytes);
    const std::string message = error_of([&] { read_volume(path); });
    EXPECT_NE(message.find(fragment), std::string::npos) << name << " message: " << message;
    EXPECT_NE(message.find(name), std::string::npos) << message;
  }
  VolumeOptions label1;
  label1.label = 1;
  EXPECT_NE(error_of([&] { read_volume(write_nifti("nan.nii", nifti_bytes(with_nan)), label1); }).find("voxel (1, 0, 1) is NaN"),
            std::string::npos);
  EXPECT_NE(error_of([&] { read_labels(write_nifti("nan.nii", nifti_bytes(with_nan))); }).find("voxel (1, 0, 1) is NaN"),
            std::string::npos);
  // Inf is a value: above the threshold, a voxel of the object (NaN is the one refused).
  levels[5] = std::numeric_limits<float>::infinity();
  NiftiSample with_inf = cube(2, raw(levels));
  with_inf.datatype = DT_FLOAT32, with_inf.bitpix = 32;
  EXPECT_EQ(read_volume(write_nifti("inf.nii", nifti_bytes(with_inf))).voxel_count(), 8);
  // The fuzzer's input that smashed nifticlib's stack (NIfTI-2, dim[0] = 849): refused before it.
  EXPECT_NE(error_of([] { read_volume(DIGILAP_SOURCE_DATA "/../fuzz/volume_corpus/regression_nifti2_dim0_849.nii"); })
                .find("dim[0] is 849 (the number of dimensions must be 1 to 7)"),
            std::string::npos);
  // And the one whose 4th to 7th dimensions multiply past 2^63 (a count no integer holds).
  EXPECT_NE(error_of([] { read_volume(DIGILAP_SOURCE_DATA "/../fuzz/volume_corpus/regression_nifti2_extra_dims_overflow.nii"); })
                .find("e+"),
            std::string::npos);
  EXPECT_NE(error_of([] { read_volume(::testing::TempDir() + "/bad.vol"); }).find("unknown extension"), std::string::npos);
  EXPECT_NE(error_of([] { read_volume("/nonexistent/volume.nii.gz"); }).find("cannot open"), std::string::npos);
  EXPECT_NE(error_of([] { read_nifti_volume(::testing::TempDir() + "/plain.npy"); }).find(".nii or .nii.gz"), std::string::npos);
}
