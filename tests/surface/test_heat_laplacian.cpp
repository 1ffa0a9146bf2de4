// surface/heat_laplacian.hpp: the surface operator against SPEC §7 (the x^2 error of the
// reference implementation, convergence, the matrix by brute force), thread independence, its
// spectrum and heat flow on the sphere, and connected surfaces as separate parts.
#include "digilap/surface/heat_laplacian.hpp"
#include "on_threads.hpp"
#include "support.hpp"
#include "surface/intrinsic_kernel.hpp"
#include "surface/surfel_tiles.hpp"

#include "digilap/surface/ground_truth.hpp"

#include <gtest/gtest.h>

#include <omp.h>
#include <cstring>
#include <limits>
#include <numeric>
#include <random>
#include <set>
#include <utility>

using namespace digilap;
using namespace digilap::surface;
using namespace digilap::surface::test_support;

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
// within 0.8% after lambda -> -ln(1 - lambda t) / t (now the cut kernel's symbol inverted).
// Here at h = 0.1 (the fine step is the next test), where we measure raw 12.1% and corrected
// 1.3%: asserted within 15% and 2%, the 3 + 5 + 7 copies within 2% of each other. Both solvers
// (the factorization and LOBPCG on products, the surfaces' method) give the same pairs.
TEST(Surface, SphereSpectrumAndHeatFlow) {
  Sphere sphere;
  sphere.set_pose(kCentre, Eigen::Matrix3d::Identity());
  const Pipeline p = run(sphere, 0.1, true, 0.1);
  SpectrumOptions factorized, products;
  factorized.count = products.count = 16;
  factorized.method = SpectrumMethod::Factorization, products.method = SpectrumMethod::Products;
  const Spectrum s = smallest_eigenpairs(p.op.A, p.op.mass, factorized);
  const Eigen::VectorXd mu = laplace_beltrami_eigenvalues(s.eigenvalues, p.op.t, nullptr, kernel_cut_of(p.op));
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

// Issue 13's must-show: the sphere at h = 0.02 with the defaults (II normals, c_t = 0.1, the
// measured length scale, the intrinsic kernel), N = 46,950, through LOBPCG on products (about
// 20 s and 4.7 GB; the factorization would not fit). Measured: l = 1..3 within 0.23% of l(l+1)
// after the bias correction, clusters split by 0.03% (l = 2) and 0.07% (l = 3); with the chord
// kernel 0.57%, 0.19% and 0.10%. Asserted: 1% and 1%, the figures. Left out of the sanitizer run (scripts/sanitize.sh) for its size.
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
  const Eigen::VectorXd lb = laplace_beltrami_eigenvalues(s.eigenvalues, op.t, nullptr, kernel_cut_of(op));
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

// Issue 25, item 3: five balls 3.4 voxels apart (the kernel's cut is larger) are five surfaces:
// five zero eigenvalues, and the first non-zero eigenvalues are each ball's own. The ambient
// coupling of earlier releases is still there on request, and joins them into one.
TEST(SurfaceParts, SeparateObjectsCloserThanTheCutAreNotCoupled) {
  const double r = 5;
  auto balls = voxels_of(90, [&](int i, int j, int k) {
    for (int b = 0; b < 5; ++b)
      if (in_ball(i, j, k, 8 + b * (2 * r + 3.4), 10, 10, r)) return true;
    return false;
  });
  const Pipeline p = run(balls);
  ASSERT_EQ(p.surfels.surfaces(), 5u);
  ASSERT_GT(p.op.cut, 3.4 + 1);  // the balls would interact through the kernel
  SpectrumOptions o;
  o.count = 10;
  const Spectrum s = smallest_eigenpairs(p.op, o);
  // LOBPCG's tolerance is 1e-10 relative to the top of the spectrum (about 1 / t): the zeros
  // are 0 to that, the first non-zero ones far above.
  for (int k = 0; k < 5; ++k) EXPECT_LT(std::abs(s.eigenvalues[k]), 1e-8 * s.eigenvalues[9]) << "k " << k;
  EXPECT_GT(s.eigenvalues[5], 1e-3 * s.eigenvalues[9]);
  // No entry of L joins two surfaces.
  for (std::size_t part = 0; part < p.op.parts(); ++part)
    for (Eigen::Index i = p.op.row_offset[part]; i < p.op.row_offset[part + 1]; ++i)
      for (SparseMatrix::InnerIterator it(p.op.L, i); it; ++it)
        ASSERT_TRUE(it.col() >= p.op.row_offset[part] && it.col() < p.op.row_offset[part + 1]) << "row " << i;
  HeatLaplacianOptions coupled;
  coupled.couple_surfaces = true;
  const Pipeline q = run(balls, coupled);
  EXPECT_EQ(q.op.parts(), 1u);
  o.count = 3;
  const Spectrum c = smallest_eigenpairs(q.op, o);
  EXPECT_GT(c.eigenvalues[1], 1e-3 * c.eigenvalues[2]);  // one zero: the balls are joined
}

// Issue 25, item 5: parts solved side by side gave eigenvalues 1e-17 and eigenvectors 0.12
// apart between 1 and 2 threads (Eigen blocked its sums for two threads inside a serial nested
// region). Two balls of different radii (two parts, each of about 1,300 surfels, solved by
// LOBPCG): the same bits for 1 and 2 threads, as for one part.
TEST(SurfaceParts, SpectraOfSeveralPartsAreBitwiseIndependentOfTheThreads) {
  const Pipeline p = run(voxels_of(48, [](int i, int j, int k) {
    return in_ball(i, j, k, 12, 24, 24, 9) || in_ball(i, j, k, 35, 24, 24, 8);
  }));
  ASSERT_EQ(p.op.parts(), 2u);
  SpectrumOptions o;
  o.count = 10;
  const Spectrum one = on_threads(1, [&] { return smallest_eigenpairs(p.op, o); });
  const Spectrum two = on_threads(2, [&] { return smallest_eigenpairs(p.op, o); });
  const std::vector<Spectrum> one_per_part = on_threads(1, [&] { return smallest_eigenpairs_per_part(p.op, o); });
  const std::vector<Spectrum> two_per_part = on_threads(2, [&] { return smallest_eigenpairs_per_part(p.op, o); });
  EXPECT_EQ(one.eigenvalues, two.eigenvalues);
  EXPECT_EQ(one.eigenvectors, two.eigenvectors);
  ASSERT_EQ(one_per_part.size(), 2u);
  for (std::size_t q = 0; q < 2; ++q) {
    EXPECT_EQ(one_per_part[q].eigenvalues, two_per_part[q].eigenvalues) << "part " << q;
    EXPECT_EQ(one_per_part[q].eigenvectors, two_per_part[q].eigenvectors) << "part " << q;
  }
}

// --- The intrinsic kernel (SurfaceKernel::Intrinsic, docs/accuracy.md "Why the torus stalls") ---

namespace {
struct Defaults {
  SurfelSet surfels;
  SurfelMeasures mu;
};
// The library's defaults (II normals, measured l, c_t = 0.1), on a surface posed off the lattice.
Defaults defaults_pipeline(const Surface& s, double h) {
  const VoxelSet voxels = digitize(s, h);
  Defaults d;
  d.surfels = extract_surfels(voxels);
  d.mu = measures(d.surfels, ii_normals(voxels, d.surfels));
  return d;
}
// The worst relative error of the first 19 nonzero Laplace-Beltrami estimates against `exact`.
// Relative errors of the 19 nonzero Laplace-Beltrami estimates of the 20 smallest eigenpairs.
Eigen::VectorXd spectrum_errors(const SurfaceOperator& op, const Eigen::VectorXd& exact) {
  SpectrumOptions o;
  o.count = 20;
  const Spectrum s = smallest_eigenpairs(op, o);
  return (s.laplace_beltrami.segment(1, 19) - exact.segment(1, 19)).cwiseQuotient(exact.segment(1, 19));
}
double worst_spectrum_error(const SurfaceOperator& op, const Eigen::VectorXd& exact) {
  return spectrum_errors(op, exact).cwiseAbs().maxCoeff();
}
SurfaceOperator with_kernel(const Defaults& d, SurfaceKernel kernel) {
  HeatLaplacianOptions o;
  o.surface_kernel = kernel;
  return heat_laplacian(d.surfels, d.mu, o);
}
}  // namespace

// The torus's spectrum (torus_spectrum, exact by separation of variables) at h = 0.05 with the
// defaults: the chord kernel stalls at 4.00% (its curvature bias, about (5/4) t / r^2 on the modes
// around the tube, and the staircase's jitter cross), the intrinsic one measures 1.47%. Asserted:
// the intrinsic kernel within 2% and at most half the chord's error. The sphere (l(l+1)) at the
// same step: 0.61% with the chord, 0.58% intrinsic; asserted within 0.8% and not worse than the
// chord by more than 0.1 point.
TEST(SurfaceIntrinsicKernel, TorusSpectrumErrorFallsAndTheSphereKeepsItsAccuracy) {
  Torus torus;  // R = 1, r = 0.4
  torus.set_pose(kCentre, Eigen::Matrix3d::Identity());
  const Defaults t = defaults_pipeline(torus, 0.05);
  const Eigen::VectorXd exact = torus_spectrum(1.0, 0.4, 20);
  const double chord = worst_spectrum_error(with_kernel(t, SurfaceKernel::Chord), exact);
  const double intrinsic = worst_spectrum_error(with_kernel(t, SurfaceKernel::Intrinsic), exact);
  EXPECT_LT(intrinsic, 0.02) << "chord " << chord;
  EXPECT_LT(intrinsic, 0.5 * chord);
  Sphere sphere;
  sphere.set_pose(kCentre, Eigen::Matrix3d::Identity());
  const Defaults s = defaults_pipeline(sphere, 0.05);
  const Eigen::VectorXd l_l1 = sphere_spectrum(1.0, 20);
  const double sphere_chord = worst_spectrum_error(with_kernel(s, SurfaceKernel::Chord), l_l1);
  const double sphere_intrinsic = worst_spectrum_error(with_kernel(s, SurfaceKernel::Intrinsic), l_l1);
  EXPECT_LT(sphere_intrinsic, 0.008);
  EXPECT_LT(sphere_intrinsic, sphere_chord + 0.001);
}

// docs/accuracy.md "Why the torus stalled": the estimates carried two biases that do not shrink
// with h, -0.123% from the kernel's cut (its second moment's lost tail; the estimates now invert
// the cut kernel's symbol) and +t/3 on the unit sphere from the curvature factors (1 + (2/3) t K,
// now 1 + t K / 2: the geodesic Gaussian's own bias is -K t). Before, the sphere's mean error
// followed t: +0.29% at c_t = 0.1 and +0.02% at 0.05 (h = 0.05, the bench's pose); now +0.00% and
// -0.05%. Asserted on the sphere: the mean error of the 19 nonzero estimates within 0.1% at both
// heat times and moving by less than 0.1 point between them (the noise of the h = 0.05 digitization
// is about 0.05%); on both surfaces, half the heat time within 0.1 point of the default's worst
// error and within 0.8%, on half the terms (t halves, at most 0.6 times the nonzeros: the
// kernel's disc, about t's area, halves).
TEST(SurfaceIntrinsicKernel, TheEstimatesCarryNoBiasThatFollowsTheHeatTime) {
  Sphere sphere;
  Torus torus;  // R = 1, r = 0.4
  sphere.set_pose(kCentre, Eigen::Matrix3d::Identity());
  torus.set_pose(kCentre, Eigen::Matrix3d::Identity());
  const std::pair<const Surface*, Eigen::VectorXd> cases[] = {{&sphere, sphere_spectrum(1.0, 20)},
                                                              {&torus, torus_spectrum(1.0, 0.4, 20)}};
  for (const auto& [surface, exact] : cases) {
    const Defaults d = defaults_pipeline(*surface, 0.05);
    HeatLaplacianOptions half;
    half.c_t = 0.05;
    const SurfaceOperator plain = heat_laplacian(d.surfels, d.mu);
    const SurfaceOperator shorter = heat_laplacian(d.surfels, d.mu, half);
    EXPECT_NEAR(shorter.t, 0.5 * plain.t, 1e-12 * plain.t);
    EXPECT_LT(shorter.L.nonZeros(), 0.6 * plain.L.nonZeros());
    const Eigen::VectorXd at_default = spectrum_errors(plain, exact), at_half = spectrum_errors(shorter, exact);
    const double worst_default = at_default.cwiseAbs().maxCoeff(), worst_half = at_half.cwiseAbs().maxCoeff();
    std::printf("%s: worst %.3f%% (c_t = 0.1), %.3f%% (0.05); mean %+.3f%%, %+.3f%%\n", surface == &sphere ? "sphere" : "torus",
                100 * worst_default, 100 * worst_half, 100 * at_default.mean(), 100 * at_half.mean());
    EXPECT_LT(worst_half, 0.008);
    EXPECT_LT(worst_default, 0.008);
    EXPECT_LT(worst_half, worst_default + 0.001);
    if (surface == &sphere) {
      EXPECT_LT(std::abs(at_default.mean()), 0.001);
      EXPECT_LT(std::abs(at_half.mean()), 0.001);
      EXPECT_LT(std::abs(at_default.mean() - at_half.mean()), 0.001);
    }
  }
}

// The intrinsic operator keeps the structure: A symmetric bit for bit (the distance and the
// factors are symmetric in i, j), rows of L summing to 0, off-diagonals >= 0, L = M^(-1) A to
// rounding, the same bits for 1 and 2 threads; on every reference surface posed off the lattice.
// And against a brute-force evaluation of its definition over all pairs, with the curvature
// factors from the operator's own weights: off-diagonal A_ij / (w_ij m_i m_j) = c_i c_j.
TEST(SurfaceIntrinsicKernel, StructureAndThreadIndependence) {
  for (const char* name : {"sphere", "ellipsoid", "torus"}) {
    const auto s = posed(make_surface(name));
    const Defaults d = defaults_pipeline(*s, 0.15);
    const SurfaceOperator one = on_threads(1, [&] { return with_kernel(d, SurfaceKernel::Intrinsic); });
    const SurfaceOperator two = on_threads(2, [&] { return with_kernel(d, SurfaceKernel::Intrinsic); });
    ASSERT_EQ(one.L.nonZeros(), two.L.nonZeros());
    EXPECT_EQ(std::memcmp(one.L.valuePtr(), two.L.valuePtr(), sizeof(double) * one.L.nonZeros()), 0) << name;
    EXPECT_EQ(std::memcmp(one.A.valuePtr(), two.A.valuePtr(), sizeof(double) * one.A.nonZeros()), 0) << name;
    const Eigen::MatrixXd L(one.L), A(one.A);
    EXPECT_EQ((A - A.transpose()).cwiseAbs().maxCoeff(), 0.0) << name;
    const Eigen::Index n = one.rows();
    for (Eigen::Index i = 0; i < n; ++i) {
      EXPECT_LE(std::abs(L.row(i).sum()), 1e-12 * std::max(1.0, std::abs(L(i, i)))) << name;
      if (one.mass[i] > 0) EXPECT_LE((A.row(i) - one.mass[i] * L.row(i)).cwiseAbs().maxCoeff(), 1e-12 * A.row(i).cwiseAbs().maxCoeff());
    }
    EXPECT_GE((L - Eigen::MatrixXd(L.diagonal().asDiagonal())).minCoeff(), 0.0) << name;
    // Against the definition over all pairs: w(d_ij) m_i m_j c_i c_j, d the intrinsic distance
    // (written out here again), c the curvature factors (one connected surface: one part).
    const Eigen::MatrixX3d& x = one.positions;
    const Eigen::MatrixX3d& nrm = d.mu.normals;
    const double t = one.t;
    ASSERT_EQ(one.row_offset.size(), 2u) << name;
    const surface::detail::Kernel kernel(t, 6.0);
    const surface::detail::Grid grid(x, kernel.cut, &nrm);
    const Eigen::VectorXd c = surface::detail::curvature_factors(grid, x, nrm, one.mass, kernel);
    int checked = 0;
    for (Eigen::Index i = 0; i < n; ++i)
      for (Eigen::Index j = 0; j < n; ++j) {
        const Eigen::Vector3d dx = (x.row(j) - x.row(i)).transpose(), sum = (nrm.row(i) + nrm.row(j)).transpose(),
                              diff = (nrm.row(j) - nrm.row(i)).transpose();
        if (i == j || dx.squaredNorm() > one.cut * one.cut) continue;
        double d2 = dx.squaredNorm();
        if (sum.squaredNorm() > 2) d2 += -std::pow(dx.dot(sum), 2) / sum.squaredNorm() + std::pow(dx.dot(diff), 2) / 12;
        const double a = std::exp(-d2 / (4 * t)) / (4 * kPi * t * t) * one.mass[i] * c[i] * one.mass[j] * c[j];
        EXPECT_NEAR(A(i, j), a, 1e-12 * std::abs(A(i, i))) << name << " " << i << " " << j;
        ++checked;
      }
    EXPECT_GT(checked, 100) << name;
  }
}

// The intrinsic distance's 1 / |s|^2 without a division (surfel_grid.hpp): a float division
// and two Newton steps, close to the exact reciprocal over the whole range it sees, |s|^2 in
// (2, 4] (normals within 90 degrees), and exactly 1 at 1 (the value the other pairs take).
// Measured: 1.25 ulp at most over 4 million values; asserted 1.5 (the plain last step,
// y (2 - s y), reaches 1.97 and fails).
TEST(SurfaceIntrinsicKernel, ReciprocalWithoutDivisionWithinOneAndAHalfUlp) {
  double worst = 0;
  for (int k = 1; k <= 1000000; ++k) {
    const double s = 2 + 2.0 * k / 1000000;
    const long double exact = 1.0L / static_cast<long double>(s);
    const double unit = std::numeric_limits<double>::epsilon() * std::pow(2.0, std::ilogb(static_cast<double>(exact)));
    worst = std::max(worst, static_cast<double>(std::fabs(static_cast<long double>(surface::detail::reciprocal_of_normals_sum(s)) - exact) / unit));
  }
  EXPECT_LE(worst, 1.5);
  EXPECT_EQ(surface::detail::reciprocal_of_normals_sum(1.0), 1.0);
}

// The products' upper triangle (surfel_grid.hpp): the same squared distances as the rows' pass
// bit for bit where a pair is kept (chord within the cut, candidate after the row), +infinity
// elsewhere, on candidates from a grid of II normals.
TEST(SurfaceIntrinsicKernel, UpperTriangleDistancesAreTheRowsOnesOrInfinity) {
  const auto s = posed(make_surface("torus"));
  const Defaults d = defaults_pipeline(*s, 0.1);
  const Eigen::MatrixX3d x = d.surfels.centres();
  const Eigen::MatrixX3d& nrm = d.mu.normals;
  const double cut = 0.45;
  const surface::detail::Grid grid(x, cut, &nrm);
  const std::size_t n = grid.items.size();
  std::vector<int> col(n);
  std::iota(col.begin(), col.end(), 0);
  std::vector<double> chord2(n), d2(n), upper(n);
  int kept = 0, left = 0;
  for (std::size_t self = 0; self < n; self += n / 7) {
    const double q[3] = {grid.xs[self], grid.ys[self], grid.zs[self]}, nq[3] = {grid.nxs[self], grid.nys[self], grid.nzs[self]};
    surface::detail::intrinsic_distances(grid.xs.data(), grid.ys.data(), grid.zs.data(), grid.nxs.data(), grid.nys.data(),
                                         grid.nzs.data(), n, q, nq, chord2.data(), d2.data());
    surface::detail::upper_intrinsic_distances(grid.xs.data(), grid.ys.data(), grid.zs.data(), grid.nxs.data(), grid.nys.data(),
                                               grid.nzs.data(), col.data(), n, q, nq, cut * cut, static_cast<int>(self), upper.data());
    for (std::size_t k = 0; k < n; ++k) {
      if (chord2[k] <= cut * cut && k > self) {
        ASSERT_EQ(std::memcmp(&upper[k], &d2[k], sizeof(double)), 0) << self << " " << k;
        ++kept;
      } else {
        ASSERT_EQ(upper[k], std::numeric_limits<double>::infinity()) << self << " " << k;
        ++left;
      }
    }
  }
  EXPECT_GT(kept, 100);
  EXPECT_GT(left, 100);
}

// The curvature factors come from an estimate of the Gaussian curvature K: on the unit sphere
// K = 1 everywhere, on the torus (R = 1, r = 0.4) K = cos(phi) / (r (R + r cos(phi))), from
// -4.17 to 1.79. At h = 0.025, measured mean absolute errors over the surfels: sphere 0.0042
// (exact normals) and 0.012 (II), torus 0.026 and 0.047; the sphere's mean K 0.9999 and 0.9987.
// Asserted: twice the measured errors, and the sphere's mean within 0.005 of 1.
TEST(SurfaceIntrinsicKernel, GaussianCurvatureEstimate) {
  for (bool exact : {true, false}) {
    for (const char* name : {"sphere", "torus"}) {
      const auto s = make_surface(name);
      s->set_pose(kCentre, Eigen::Matrix3d::Identity());
      const VoxelSet voxels = digitize(*s, 0.025);
      const SurfelSet surfels = extract_surfels(voxels);
      const SurfelNormals normals = exact ? exact_normals(*s, surfels) : ii_normals(voxels, surfels);
      const SurfelMeasures mu = measures(surfels, normals);
      const Eigen::MatrixX3d x = surfels.centres();
      const surface::detail::Kernel kernel(heat_time(surfels.h, {}, mu.length_scale), 6.0);
      const surface::detail::Grid grid(x, kernel.cut, &mu.normals);
      const Eigen::VectorXd K = surface::detail::estimated_gaussian_curvature(grid, x, mu.normals, mu.mu, kernel);
      double error = 0;
      for (Eigen::Index i = 0; i < x.rows(); ++i) {
        const Eigen::Vector3d p = s->closest_point(x.row(i).transpose()) - kCentre;
        double truth = 1;
        if (std::string(name) == "torus") {
          const double rho = std::hypot(p.x(), p.y()), cos_phi = (rho - 1) / std::hypot(rho - 1, p.z());
          truth = cos_phi / (0.4 * (1 + 0.4 * cos_phi));
        }
        error += std::abs(K[i] - truth);
      }
      error /= static_cast<double>(x.rows());
      const bool sphere = std::string(name) == "sphere";
      if (sphere) EXPECT_NEAR(K.mean(), 1.0, 0.005) << "exact normals " << exact;
      EXPECT_LT(error, sphere ? (exact ? 0.0085 : 0.025) : (exact ? 0.05 : 0.095)) << name << ", exact normals " << exact;
    }
  }
}

// Measures without normals (built by hand) cannot give the intrinsic kernel: a clear error.
TEST(SurfaceIntrinsicKernel, MeasuresWithoutNormalsAreRefused) {
  Sphere sphere;
  Defaults d = defaults_pipeline(sphere, 0.2);
  d.mu.normals.resize(0, 3);
  HeatLaplacianOptions o;
  o.surface_kernel = SurfaceKernel::Intrinsic;
  EXPECT_THROW(heat_laplacian(d.surfels, d.mu, o), Error);
  o.surface_kernel = SurfaceKernel::Chord;
  EXPECT_NO_THROW(heat_laplacian(d.surfels, d.mu, o));  // the chord needs none
  o.surface_kernel = SurfaceKernel::Intrinsic;
  d = defaults_pipeline(sphere, 0.2);
  d.mu.normals(3, 1) = std::nan("");
  EXPECT_THROW(heat_laplacian(d.surfels, d.mu, o), Error);
}

// The curvature pass takes rows a tile at a time over shared candidates (surfel_tiles.hpp), each
// pair once from its first row's tile: each row's K must be the definition's over all its
// neighbours within the cut, whatever the grid's cells (the assembled operator's grid has 4
// cells a cut, the products' 2, with the longest axis slowest), and the same bits on 1, 2 or 3
// threads (several layers of cells write into the same rows' sums). Written out
// here over every pair, on II normals: noisy on the sphere and torus, so that neighbours across a
// tile's edge matter; and on label 29 of the 2 mm JHU atlas, which has pairs of normals 90
// degrees apart up to rounding (|n_i + n_j|^2 = 2, the test's boundary): an FMA in the vectorized
// build and not in the scalar one changed the decision there, and that label's K by 3%.
// Tolerance: the sums hold hundreds of terms, added in another order here, and K = 2 H^2 -
// turn/weight can lose a few digits to cancellation: 1e-9 of the terms' scale 2 H^2 + turn/weight.
// A tile whose candidates missed neighbours (the reach without the tile's radius) is off by 2e-3.
TEST(SurfaceIntrinsicKernel, CurvatureFromTilesEqualsTheDefinitionOverAllPairs) {
  for (const char* name : {"sphere", "torus", "label 29"}) {
    VolumeOptions label;
    label.label = 29;
    VoxelSet voxels = read_volume(DIGILAP_SOURCE_DATA "/JHU-WhiteMatter-labels-2mm.nii.gz", label);
    if (std::string(name) != "label 29") {
      const auto s = make_surface(name);
      s->set_pose(kCentre, Eigen::Matrix3d::Identity());
      voxels = digitize(*s, 0.1);
    }
    const SurfelSet surfels = extract_surfels(voxels);
    const SurfelMeasures mu = measures(surfels, ii_normals(voxels, surfels));
    const Eigen::MatrixX3d x = surfels.centres();
    const Eigen::MatrixX3d& nrm = mu.normals;
    const surface::detail::Kernel kernel(heat_time(surfels.h, {}, mu.length_scale), 6.0);
    const Eigen::Index n = x.rows();
    Eigen::VectorXd truth(n), scale(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      double weight = 0, bend = 0, turn = 0;
      for (Eigen::Index j = 0; j < n; ++j) {
        const Eigen::Vector3d d = (x.row(j) - x.row(i)).transpose(), sum = (nrm.row(i) + nrm.row(j)).transpose(),
                              e = (nrm.row(j) - nrm.row(i)).transpose();
        if (d.squaredNorm() == 0 || d.squaredNorm() > kernel.cut * kernel.cut || sum.squaredNorm() <= 2) continue;
        const double rho2 = d.squaredNorm() - std::pow(d.dot(sum), 2) / sum.squaredNorm();
        const double w = std::exp(-rho2 / (4 * kernel.t)) * mu.mu[j];
        weight += w * rho2, bend += w * d.dot(e), turn += w * e.squaredNorm();
      }
      const double mean = bend / weight;
      truth[i] = 2 * mean * mean - turn / weight;
      scale[i] = 2 * mean * mean + turn / weight;
    }
    for (const bool longest_slowest : {false, true})
      for (double cells_per_cut : {2.0, 4.0}) {
        const surface::detail::Grid grid(x, kernel.cut, &nrm, cells_per_cut, longest_slowest);
        auto k_on = [&](int threads) {
          return on_threads(threads, [&] { return surface::detail::estimated_gaussian_curvature(grid, x, nrm, mu.mu, kernel); });
        };
        const Eigen::VectorXd K = k_on(2);
        Eigen::Index worst = 0;
        const double error = ((K - truth).cwiseAbs().array() / scale.array()).maxCoeff(&worst);
        EXPECT_LE(error, 1e-9) << name << ", " << cells_per_cut << " cells a cut: surfel " << worst << " K " << K[worst] << " against "
                               << truth[worst];
        // Each pair once, its shares added layer distance by layer distance: the same bits on any threads.
        for (int threads : {1, 3}) {
          const Eigen::VectorXd other = k_on(threads);
          EXPECT_EQ(std::memcmp(K.data(), other.data(), sizeof(double) * static_cast<std::size_t>(n)), 0)
              << name << ", " << cells_per_cut << " cells a cut, " << threads << " threads";
        }
        EXPECT_GE(grid.layers(), 2) << name;  // layers that write into the same rows, on different threads
      }
  }
}

TEST(SurfaceGrid, LongestAxisSlowestFindsEveryPairWithinItsReachInLayers) {
  // The matrix-free products take each pair once, from the tile of its first item, and write
  // its second item's image by how many layers of cells (along the grid's slowest axis) lie
  // between them (matrix_free.cpp). So for either order of the cells: every pair within the
  // cut among the tile's candidates from its first item on, those candidates in the grid's order,
  // and no pair more than `reach` layers apart. Points in a flat box longest along x, whose grid
  // then runs in layers along x (20 of them against 4 along z), and the same box stood on end
  // (longest along z: the usual order stays), and a cube (a tie: the usual order too).
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  const int n = 3000;
  for (int shape : {0, 1, 2}) {
  const bool flat = shape == 0;
  Eigen::MatrixX3d p(n, 3);
  for (int i = 0; i < n; ++i) p.row(i) << 3 * u(rng), u(rng), 0.5 * u(rng);
  if (shape == 1) p.col(0).swap(p.col(2));
  if (shape == 2) {
    p.col(0) /= 3, p.col(2) *= 2;
    p.row(0).setZero(), p.row(1).setOnes();  // extents exactly 1 on every axis
  }
  const double cut = 0.3;
  for (bool longest_slowest : {false, true}) {
    const surface::detail::Grid grid(p, cut, nullptr, 2, longest_slowest);
    const int slowest = longest_slowest && flat ? 0 : 2;
    EXPECT_EQ(grid.axis[2], slowest);
    EXPECT_NE(grid.axis[0], grid.axis[1]);
    EXPECT_EQ(grid.axis[0] + grid.axis[1] + grid.axis[2], 3);  // a permutation of 0, 1, 2
    EXPECT_EQ(grid.layers(), grid.count(slowest));
    const surface::detail::Tiles tiles(grid);
    surface::detail::TileBuffer buffer;
    auto layer_of = [&](Eigen::Index item) {
      Eigen::Index l = 0;
      while (grid.start[static_cast<std::size_t>((l + 1) * grid.cells_per_layer())] <= item) ++l;
      return l;
    };
    long missing = 0, too_far = 0, unsorted = 0, pairs = 0;
    for (Eigen::Index tile = 0; tile < tiles.size(); ++tile) {
      const Eigen::Index first = tiles.first(tile);
      const std::size_t count = surface::detail::gather_tile_candidates(grid, first, tiles.rows(tile), cut, nullptr, buffer, first);
      for (std::size_t k = 1; k < count; ++k) unsorted += buffer.col[k] <= buffer.col[k - 1];
      const std::set<int> candidates(buffer.col.begin(), buffer.col.begin() + static_cast<std::ptrdiff_t>(count));
      for (Eigen::Index i = first; i < first + tiles.rows(tile); ++i)
        for (Eigen::Index j = i + 1; j < n; ++j) {
          if (grid.distance2(Eigen::Vector3d(grid.xs[i], grid.ys[i], grid.zs[i]), j) > cut * cut) continue;
          ++pairs;
          missing += !candidates.count(static_cast<int>(j));
          too_far += layer_of(j) > layer_of(i) + grid.reach;
        }
    }
    EXPECT_GT(pairs, 100000);  // the premise: many pairs, across many layers
    EXPECT_EQ(missing, 0) << longest_slowest;
    EXPECT_EQ(too_far, 0) << longest_slowest;
    EXPECT_EQ(unsorted, 0) << longest_slowest;
  }
  }
}
