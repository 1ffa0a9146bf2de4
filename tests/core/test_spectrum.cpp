// Spectrum: eigenvalues against SPEC §5, M-orthonormality, several contours, clear errors.
#include "digilap/core/error.hpp"
#include "digilap/curve/image.hpp"
#include "digilap/curve/matrix_free.hpp"
#include "digilap/curve/spectrum.hpp"

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <omp.h>

using namespace digilap;

namespace {
constexpr double kPi = 3.14159265358979323846;

ContourOperator operator_of(const Shape& shape, double h, const HeatLaplacianOptions& o = {}) {
  const DigitalSet set = digitize(shape, h);
  const ContourSet cs = track_contours(set);
  return heat_laplacian(cs, measures(cs, ii_normals(set, cs)), o);
}
}  // namespace

TEST(Spectrum, EigenvectorsAreMOrthonormalAndSolveTheProblem) {
  const ContourOperator op = operator_of(Flower(), 0.02);
  const Spectrum s = smallest_eigenpairs(op);
  const Eigen::MatrixXd gram = s.eigenvectors.transpose() * op.mass.asDiagonal() * s.eigenvectors;
  EXPECT_LE((gram - Eigen::MatrixXd::Identity(gram.rows(), gram.cols())).cwiseAbs().maxCoeff(), 1e-9);
  for (Eigen::Index k = 0; k < s.eigenvalues.size(); ++k) {
    const Eigen::VectorXd x = s.eigenvectors.col(k);
    const Eigen::VectorXd residual = -(op.A * x) - s.eigenvalues[k] * op.mass.cwiseProduct(x);
    EXPECT_LE(residual.norm(), 1e-7 * (op.A * x).norm() + 1e-12) << k;
  }
  for (Eigen::Index k = 1; k < s.eigenvalues.size(); ++k) EXPECT_GE(s.eigenvalues[k], s.eigenvalues[k - 1]);
}

TEST(Spectrum, FlowerEigenvaluesWithinOnePercentOfTheExactOnes) {
  Flower flower;
  const ContourOperator op = operator_of(flower, 0.005);
  const Spectrum s = smallest_eigenpairs(op, {11});
  for (int m = 1; m <= 5; ++m) {
    const double exact = std::pow(2 * kPi * m / flower.length(), 2);
    for (int k : {2 * m - 1, 2 * m}) EXPECT_NEAR(s.eigenvalues[k], exact, 0.01 * exact) << "m = " << m;
  }
}

TEST(Spectrum, OneZeroEigenvaluePerContour) {
  // Two discs: two eigenvalues 0 (one constant per contour), then positive ones.
  std::vector<std::uint8_t> bits(50 * 30, 0);
  for (int r = 0; r < 30; ++r)
    for (int c = 0; c < 50; ++c) bits[r * 50 + c] = std::hypot(r - 15, c - 12) < 10 || std::hypot(r - 15, c - 37) < 8;
  const DigitalSet set = DigitalSet::from_bitmap(0.02, 50, 30, bits);
  const ContourSet cs = track_contours(set);
  ASSERT_EQ(cs.contours.size(), 2u);
  const ContourOperator op = heat_laplacian(cs, measures(cs, ii_normals(set, cs, {0.3})));
  const Spectrum s = smallest_eigenpairs(op, {4});
  EXPECT_LE(std::abs(s.eigenvalues[0]), 1e-8 * s.eigenvalues[2]);
  EXPECT_LE(std::abs(s.eigenvalues[1]), 1e-8 * s.eigenvalues[2]);
  EXPECT_GT(s.eigenvalues[2], 1.0);
}

TEST(Spectrum, ClearErrors) {
  const ContourOperator op = operator_of(Circle(), 0.1);
  EXPECT_THROW(smallest_eigenpairs(op, {0}), Error);
  EXPECT_THROW(smallest_eigenpairs(op, {static_cast<int>(op.rows())}), Error);
  Eigen::VectorXd bad_mass = op.mass;
  bad_mass[3] = -1e-3;  // a zero mass is off the support (tests/core/test_operator.cpp); a negative one is wrong
  try {
    smallest_eigenpairs(op.A, bad_mass);
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("mass of row 3"), std::string::npos) << e.what();
  }
  // A Krylov space barely larger than the request, one restart, an unreachable tolerance:
  // Spectra reports non-convergence, and so do we, with the numbers.
  SpectrumOptions starved;
  starved.count = 10;
  starved.subspace = 11;
  starved.max_iterations = 1;
  starved.tolerance = 1e-14;  // the smallest accepted
  try {
    smallest_eigenpairs(operator_of(Flower(), 0.01), starved);
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("did not converge"), std::string::npos) << e.what();
  }
}

// --- Repeated eigenvalues (issue 15, item 1) -------------------------------------------------

namespace {

struct ContourProblem {
  std::string name;
  ContourSet contours;
  Measures mu;
  HeatLaplacianOptions options;
};

// Squares of the given sizes (pixels) in one row, `gap` pixels apart, grid step h.
ContourProblem squares(const std::string& name, const std::vector<int>& sizes, int gap, double h, double t) {
  std::vector<Eigen::Vector2i> pixels;
  int x = 0;
  for (int s : sizes) {
    for (int j = 0; j < s; ++j)
      for (int i = 0; i < s; ++i) pixels.emplace_back(x + i, j);
    x += s + gap;
  }
  const DigitalSet set = DigitalSet::from_pixels(h, pixels);
  ContourProblem p{name, track_contours(set), {}, {}};
  IINormalOptions normal_options;
  normal_options.k_R = 0.3;
  p.mu = measures(p.contours, ii_normals(set, p.contours, normal_options));
  p.options.t = t;
  return p;
}

// The sets the tests solve: the image of ten identical squares, thirty identical small
// squares (0 thirty times), and contours of different sizes and kinds (squares of 5..9
// pixels, a disc and an annulus: one contour then has a hole's orientation).
std::vector<ContourProblem> multi_contour_sets() {
  std::vector<ContourProblem> sets;
  {
    const DigitalSet set = binarize(read_image(std::string(DIGILAP_SOURCE_DATA) + "/ten_squares.pbm"), {0.02});
    ContourProblem p{"ten_squares.pbm", track_contours(set), {}, {}};
    IINormalOptions normal_options;
    normal_options.k_R = 0.3;
    p.mu = measures(p.contours, ii_normals(set, p.contours, normal_options));
    p.options.t = 4e-4;
    sets.push_back(std::move(p));
  }
  sets.push_back(squares("thirty 5-pixel squares", std::vector<int>(30, 5), 4, 0.02, 4e-4));
  {
    ContourProblem p = squares("squares of 5..9 pixels", {5, 6, 7, 8, 9, 7, 5}, 4, 0.02, 4e-4);
    sets.push_back(std::move(p));
  }
  {
    std::vector<std::uint8_t> bits(30 * 30);
    for (int r = 0; r < 30; ++r)
      for (int c = 0; c < 30; ++c) {
        const double d = std::hypot(r - 14.5, c - 14.5);
        bits[r * 30 + c] = (d < 14 && d > 9) || d < 5;
      }
    const DigitalSet set = DigitalSet::from_bitmap(0.02, 30, 30, bits);
    ContourProblem p{"annulus and disc", track_contours(set), {}, {}};
    IINormalOptions normal_options;
    normal_options.k_R = 0.3;
    p.mu = measures(p.contours, ii_normals(set, p.contours, normal_options));
    p.options.t = 1e-3;
    sets.push_back(std::move(p));
  }
  {  // Two identical discs of 480 rows each: above the dense size, so Lanczos and LOBPCG run.
    std::vector<std::uint8_t> bits(260 * 122);
    for (int r = 0; r < 122; ++r)
      for (int c = 0; c < 260; ++c) bits[r * 260 + c] = std::hypot(r - 60.5, (c % 130) - 60.5) < 60;
    const DigitalSet set = DigitalSet::from_bitmap(0.01, 260, 122, bits);
    ContourProblem p{"two identical discs", track_contours(set), {}, {}};
    p.mu = measures(p.contours, ii_normals(set, p.contours));
    sets.push_back(std::move(p));
  }
  return sets;
}

// All eigenvalues of -A x = lambda M x, ascending, by a dense generalized solver.
Eigen::VectorXd dense_eigenvalues(const SparseMatrix& A, const Eigen::VectorXd& mass) {
  Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> eig(-Eigen::MatrixXd(A), Eigen::MatrixXd(mass.asDiagonal()));
  return eig.eigenvalues();
}

// |C y - lambda y| for the pair in symmetric form, relative to the spectrum's bound.
double worst_residual(const ContourOperator& op, const Spectrum& s) {
  double worst = 0;
  for (Eigen::Index k = 0; k < s.eigenvalues.size(); ++k) {
    const Eigen::VectorXd r = -op.A * s.eigenvectors.col(k) - s.eigenvalues[k] * op.mass.cwiseProduct(s.eigenvectors.col(k));
    worst = std::max(worst, r.cwiseQuotient(op.mass.cwiseSqrt()).norm());
  }
  return worst;
}

}  // namespace

// Both solvers return every copy: against a dense solver, the `count` smallest eigenvalues of
// each set agree (before, the factorized path dropped copies and the matrix-free one returned
// 6 zeros for 10 contours, or 20 of 30, then larger eigenvalues, all with small residuals).
TEST(Spectrum, RepeatedEigenvaluesOfSeveralContoursAreAllFound) {
  for (const ContourProblem& p : multi_contour_sets()) {
    const ContourOperator op = heat_laplacian(p.contours, p.mu, p.options);
    const Eigen::VectorXd exact = dense_eigenvalues(op.A, op.mass);
    const double scale = exact[exact.size() - 1];
    SpectrumOptions so;
    so.count = static_cast<int>(std::min<std::size_t>(3 * p.contours.contours.size() + 5, exact.size() - 1));
    const Spectrum factorized = smallest_eigenpairs(op, so);
    const MatrixFreeLaplacian mf(p.contours, p.mu, p.options);
    const Spectrum matrix_free = smallest_eigenpairs(mf, so);
    ASSERT_EQ(factorized.eigenvalues.size(), so.count) << p.name;
    ASSERT_EQ(matrix_free.eigenvalues.size(), so.count) << p.name;
    // The dense solver's own rounding is about 1e-13 of the largest eigenvalue; the matrix-free
    // product adds its epsilon (1e-10 relative to the operator's scale).
    for (int k = 0; k < so.count; ++k) {
      EXPECT_NEAR(factorized.eigenvalues[k], exact[k], 1e-11 * scale) << p.name << ", k = " << k;
      EXPECT_NEAR(matrix_free.eigenvalues[k], exact[k], 1e-8 * scale) << p.name << ", k = " << k;
    }
    const Eigen::MatrixXd gram = factorized.eigenvectors.transpose() * op.mass.asDiagonal() * factorized.eigenvectors;
    EXPECT_LE((gram - Eigen::MatrixXd::Identity(so.count, so.count)).cwiseAbs().maxCoeff(), 1e-9) << p.name;
    EXPECT_LE(worst_residual(op, factorized), 1e-8 * scale) << p.name;
    EXPECT_LE(worst_residual(op, matrix_free), 1e-7 * scale) << p.name;
    // Exactly one zero per contour: the count of eigenvalues below half the first non-zero one.
    const Eigen::Index zeros = (factorized.eigenvalues.array() < 0.5 * exact[p.contours.contours.size()]).count();
    EXPECT_EQ(zeros, static_cast<Eigen::Index>(std::min<std::size_t>(p.contours.contours.size(), so.count))) << p.name;
    std::printf("%s: %zu contours, N = %ld, %d eigenpairs equal the dense ones (lambda_%d = %.6g)\n", p.name.c_str(),
                p.contours.contours.size(), static_cast<long>(op.rows()), so.count, so.count - 1,
                factorized.eigenvalues[so.count - 1]);
  }
}

// The spectrum per contour: each contour's pairs equal a dense solve of its own block, for
// both solvers, and their union is the joint spectrum.
TEST(Spectrum, PerContourSpectraEqualEachContoursOwnBlock) {
  for (const ContourProblem& p : multi_contour_sets()) {
    const ContourOperator op = heat_laplacian(p.contours, p.mu, p.options);
    SpectrumOptions so;
    so.count = 7;
    const std::vector<Spectrum> per_contour = smallest_eigenpairs_per_contour(op, so);
    const std::vector<Spectrum> per_contour_mf = smallest_eigenpairs_per_contour(MatrixFreeLaplacian(p.contours, p.mu, p.options), so);
    ASSERT_EQ(per_contour.size(), p.contours.contours.size());
    ASSERT_EQ(per_contour_mf.size(), p.contours.contours.size());
    std::vector<double> all;
    for (std::size_t c = 0; c < per_contour.size(); ++c) {
      const Eigen::Index first = op.row_offset[c], n = op.row_offset[c + 1] - first;
      const SparseMatrix block = op.A.block(first, first, n, n);
      const Eigen::VectorXd exact = dense_eigenvalues(block, op.mass.segment(first, n));
      const double scale = exact[n - 1];
      ASSERT_EQ(per_contour[c].eigenvalues.size(), std::min<Eigen::Index>(so.count, n));
      ASSERT_EQ(per_contour[c].eigenvectors.rows(), n);
      for (Eigen::Index k = 0; k < per_contour[c].eigenvalues.size(); ++k) {
        EXPECT_NEAR(per_contour[c].eigenvalues[k], exact[k], 1e-11 * scale) << p.name << ", contour " << c;
        EXPECT_NEAR(per_contour_mf[c].eigenvalues[k], exact[k], 1e-8 * scale) << p.name << ", contour " << c;
        all.push_back(per_contour[c].eigenvalues[k]);
      }
    }
    std::sort(all.begin(), all.end());
    so.count = 12;
    const Spectrum joint = smallest_eigenpairs(op, so);
    for (int k = 0; k < so.count; ++k) EXPECT_NEAR(joint.eigenvalues[k], all[k], 1e-11 * std::abs(all.back())) << p.name;
  }
  // Contours that interact (Euclidean distance, the squares 3 pixels apart) have no spectrum of
  // their own: refused with the reason.
  ContourProblem p = squares("two squares", {6, 6}, 3, 0.02, 4e-4);
  p.options.distance = DistanceMode::Euclidean;
  try {
    smallest_eigenpairs_per_contour(heat_laplacian(p.contours, p.mu, p.options));
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("interacts with another one"), std::string::npos) << e.what();
  }
}

// Issue 15, item 7: the matrix-free spectrum (LOBPCG's dense block algebra) is the same bit
// for bit for 1 and 2 threads, eigenvectors included (they differed by up to 0.69: sign flips
// and rotations inside near-degenerate pairs), and so is the factorized one.
TEST(Spectrum, BitwiseIdenticalForOneAndTwoThreads) {
  const DigitalSet set = digitize(Flower(), 0.002);
  const ContourSet cs = track_contours(set);
  const Measures mu = measures(cs, ii_normals(set, cs));
  const MatrixFreeLaplacian mf(cs, mu);
  const ContourOperator op = heat_laplacian(cs, mu);
  SpectrumOptions so;
  so.count = 9;
  const int threads = omp_get_max_threads();
  Spectrum one[2], two[2];
  omp_set_num_threads(1);
  one[0] = smallest_eigenpairs(mf, so);
  one[1] = smallest_eigenpairs(op, so);
  omp_set_num_threads(2);
  two[0] = smallest_eigenpairs(mf, so);
  two[1] = smallest_eigenpairs(op, so);
  omp_set_num_threads(threads);
  for (int path = 0; path < 2; ++path) {
    ASSERT_EQ(one[path].eigenvectors.size(), two[path].eigenvectors.size());
    EXPECT_EQ(std::memcmp(one[path].eigenvalues.data(), two[path].eigenvalues.data(), sizeof(double) * one[path].eigenvalues.size()), 0)
        << (path ? "factorized" : "matrix-free") << ": max difference "
        << (one[path].eigenvalues - two[path].eigenvalues).cwiseAbs().maxCoeff();
    EXPECT_EQ(std::memcmp(one[path].eigenvectors.data(), two[path].eigenvectors.data(), sizeof(double) * one[path].eigenvectors.size()), 0)
        << (path ? "factorized" : "matrix-free") << ": max difference "
        << (one[path].eigenvectors - two[path].eigenvectors).cwiseAbs().maxCoeff();
  }
}

// --- Laplace-Beltrami eigenvalues (issue 12, item 4) -------------------------------------------

// The ellipse a = 2, b = 1 at h = 0.002: the raw eigenvalues carry the heat kernel's bias
// (1 - exp(-omega^2 t)) / t, about 0.35% low for m = 5 at the defaults; -ln(1 - lambda t) / t
// undoes it: within 0.1% of (2 pi m / P)^2 with the exact length P (measured: 1.5e-5).
TEST(Spectrum, LaplaceBeltramiEstimatesUndoTheHeatKernelBias) {
  Ellipse ellipse(2, 1);
  const ContourOperator op = operator_of(ellipse, 0.002);
  const Spectrum s = smallest_eigenpairs(op, {11});
  ASSERT_EQ(s.laplace_beltrami.size(), 11);
  EXPECT_EQ(s.undefined_estimates, 0);
  for (int m = 1; m <= 5; ++m) {
    const double exact = heat_kernel_eigenvalue(m, ellipse.length(), 0.0);
    for (int k : {2 * m - 1, 2 * m}) EXPECT_NEAR(s.laplace_beltrami[k], exact, 1e-3 * exact) << "m = " << m;
  }
  EXPECT_GT(std::abs(s.eigenvalues[10] / heat_kernel_eigenvalue(5, ellipse.length(), 0.0) - 1), 2e-3);
}

// A one-pixel-wide line (its contour goes along one side and back along the other) with a
// heat time that makes the bias large: the raw lambda for m = 5 is more than 5% below
// (2 pi m / P)^2, the estimate within 0.5% (P the estimated length: an image has no other).
TEST(Spectrum, LaplaceBeltramiEstimatesOnALineImage) {
  std::vector<Eigen::Vector2i> pixels;
  for (int i = 0; i < 200; ++i) pixels.emplace_back(i, 0);
  const DigitalSet set = DigitalSet::from_pixels(1.0 / 200, pixels);
  const ContourSet cs = track_contours(set);
  HeatLaplacianOptions o;
  o.t = 5e-4;
  const ContourOperator op = heat_laplacian(cs, measures(cs, ii_normals(set, cs)), o);
  const Spectrum s = smallest_eigenpairs(op, {11});
  const double P = op.contour_length[0];
  for (int m = 1; m <= 5; ++m) {
    const double exact = heat_kernel_eigenvalue(m, P, 0.0);
    for (int k : {2 * m - 1, 2 * m}) EXPECT_NEAR(s.laplace_beltrami[k], exact, 5e-3 * exact) << "m = " << m;
  }
  EXPECT_LT(s.eigenvalues[10], 0.95 * heat_kernel_eigenvalue(5, P, 0.0));
  std::printf("line: m = 5, raw %.4f, estimate %.4f, (2 pi m / P)^2 = %.4f\n", s.eigenvalues[10], s.laplace_beltrami[10],
              heat_kernel_eigenvalue(5, P, 0.0));
}

// The cut kernel's symbol, written out independently of the library's (which integrates the
// whole Gaussian's closed form minus a Gauss-Legendre tail): F(a) = the cut kernel's average of
// 1 - cos(omega . y), a = omega^2 t, by composite Simpson over the ball itself (r = |y| / 2 sqrt(t)
// in [0, k/2]; 2 r exp(-r^2) (1 - J0(2 sqrt(a) r)) in 2D, (2 / sqrt(pi)) exp(-r^2) (1 - cos) in 1D).
// 20,000 panels: the integrand's fourth derivative is O(10^3) at a = 5, so the rule errs below 1e-13.
double cut_kernel_symbol(int dimension, double k, double a) {
  const int panels = 20000;
  const double R = k / 2, dr = R / panels, s = 2 * std::sqrt(a);
  auto f = [&](double r) {
    return dimension == 2 ? 2 * r * std::exp(-r * r) * (1 - std::cyl_bessel_j(0.0, s * r))
                          : 2 / std::sqrt(M_PI) * std::exp(-r * r) * (1 - std::cos(s * r));
  };
  double sum = f(0) + f(R);
  for (int i = 1; i < panels; ++i) sum += (i % 2 ? 4 : 2) * f(i * dr);
  return sum * dr / 3;
}

// On a flat manifold the heat-kernel operator cut at k sqrt(t) has the eigenvalue F(mu t) / t
// where the Laplacian has mu: the estimates give mu back from it, in one and two dimensions and
// for several cuts, to 1e-10 (Newton's tolerance is 1e-15; the reference's quadrature above,
// 1e-13, is what limits). Without a cut they are -ln(1 - lambda t) / t bit for bit, as before.
// At small a the cut kernel lacks its second moment's tail, (1 + k^2/4) e^(-k^2/4) in 2D and
// erfc(k/2) + k e^(-k^2/4) / sqrt(pi) in 1D: the estimate is the whole Gaussian's divided by 1 minus
// that (0.1234% and 0.0440% at k = 6), to O(a) times the fourth moment's lost share.
TEST(Spectrum, LaplaceBeltramiEstimatesInvertTheCutKernelsSymbol) {
  const double t = 2e-3;
  for (int dimension : {1, 2})
    for (double k : {4.0, 6.0, 8.0})
      for (double a : {1e-4, 0.01, 0.2, 1.0, 3.0}) {
        const Eigen::VectorXd lambda = Eigen::VectorXd::Constant(1, cut_kernel_symbol(dimension, k, a) / t);
        int undefined = -1;
        const double mu = laplace_beltrami_eigenvalues(lambda, t, &undefined, KernelCut{dimension, k})[0];
        EXPECT_EQ(undefined, 0);
        EXPECT_NEAR(mu * t, a, 1e-10 * a) << "d = " << dimension << ", k = " << k << ", a = " << a;
        if (a == 1e-4) {
          const double u = k * k / 4, lost = dimension == 2 ? (1 + u) * std::exp(-u) : std::erfc(k / 2) + k * std::exp(-u) / std::sqrt(M_PI);
          const double whole = laplace_beltrami_eigenvalues(lambda, t)[0];
          // The next order is a times the fourth moment's lost share, (u^2 + 2u + 2) e^(-u) / 2 in 2D.
          EXPECT_NEAR(whole / mu, 1 - lost, a * (u * u + 2 * u + 2) * std::exp(-u) + 1e-9) << "d = " << dimension << ", k = " << k;
        }
      }
  const Eigen::Vector3d lambda(0.5, 100.0, 400.0);
  const Eigen::VectorXd whole = laplace_beltrami_eigenvalues(lambda, t), infinite = laplace_beltrami_eigenvalues(lambda, t, nullptr, KernelCut{1, INFINITY});
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(whole[i], -std::log1p(-lambda[i] * t) / t);
    EXPECT_EQ(infinite[i], whole[i]);
  }
  // The cut kernel's spectrum ends at its mass, 1 - e^(-9) in 2D at k = 6: no estimate above it.
  int undefined = -1;
  const Eigen::VectorXd top = laplace_beltrami_eigenvalues(Eigen::Vector2d(0.99995 / t, 0.9 / t), t, &undefined, KernelCut{2, 6.0});
  EXPECT_TRUE(std::isinf(top[0]) && top[0] > 0);
  EXPECT_TRUE(std::isfinite(top[1]) && top[1] > -std::log1p(-0.9) / t);
  EXPECT_EQ(undefined, 1);
  EXPECT_THROW(laplace_beltrami_eigenvalues(lambda, t, nullptr, KernelCut{3, 6.0}), Error);
  EXPECT_THROW(laplace_beltrami_eigenvalues(lambda, t, nullptr, KernelCut{2, 0.0}), Error);
  EXPECT_THROW(laplace_beltrami_eigenvalues(lambda, t, nullptr, KernelCut{2, NAN}), Error);
}

// Where lambda t >= 1 there is no estimate: +infinity and a count, never NaN.
TEST(Spectrum, LaplaceBeltramiEstimateIsUndefinedAboveOneOverT) {
  int undefined = -1;
  const Eigen::VectorXd mu = laplace_beltrami_eigenvalues(Eigen::Vector3d(0.5, 1.0, 2.0), 1.0, &undefined);
  EXPECT_DOUBLE_EQ(mu[0], std::log(2.0));
  EXPECT_TRUE(std::isinf(mu[1]) && mu[1] > 0);
  EXPECT_TRUE(std::isinf(mu[2]) && mu[2] > 0);
  EXPECT_EQ(undefined, 2);
  EXPECT_THROW(laplace_beltrami_eigenvalues(mu, 0.0), Error);
  const Spectrum s = smallest_eigenpairs(operator_of(Circle(), 0.1), {75});
  EXPECT_GT(s.undefined_estimates, 0);
  for (Eigen::Index k = 0; k < s.laplace_beltrami.size(); ++k) EXPECT_FALSE(std::isnan(s.laplace_beltrami[k]));
}
