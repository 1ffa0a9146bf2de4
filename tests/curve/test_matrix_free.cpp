// The matrix-free operator against the explicit matrix; spectrum and CG heat step through it;
// the cyclic tridiagonal solver of its eigen solver's preconditioner.
#include "digilap/core/error.hpp"
#include "digilap/curve/ground_truth.hpp"
#include "digilap/core/heat_flow.hpp"
#include "digilap/curve/matrix_free.hpp"
#include "digilap/curve/spectrum.hpp"
#include "curve/cyclic_tridiagonal.hpp"  // internal (lib/): the preconditioner's solver

#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

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
// An annulus (outer contour and hole) and a separate small disc on a 240 x 240 pixel grid:
// three contours of different lengths.
Pipeline annulus_and_disc() {
  const int size = 240;
  std::vector<std::uint8_t> bitmap(static_cast<std::size_t>(size) * size, 0);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const double r = std::hypot(x - 90.5, y - 120.5), d = std::hypot(x - 205.5, y - 120.5);
      bitmap[static_cast<std::size_t>(y) * size + x] = (r < 80 && r > 35) || d < 25;
    }
  const DigitalSet set = DigitalSet::from_bitmap(1.0 / size, size, size, bitmap);
  Pipeline s{track_contours(set), {}};
  s.mu = measures(s.contours, ii_normals(set, s.contours));
  return s;
}
// The product's loops are built twice, plain and for AVX2 + FMA (chosen by the CPU at
// construction; DIGILAP_PLAIN_KERNELS=1 keeps the plain ones). The agreement tests run both.
struct KernelChoice {
  explicit KernelChoice(bool plain) { setenv("DIGILAP_PLAIN_KERNELS", plain ? "1" : "0", 1); }
  ~KernelChoice() { unsetenv("DIGILAP_PLAIN_KERNELS"); }
};
}  // namespace

TEST(MatrixFree, AgreesWithTheExplicitOperatorToEpsilonOnEveryReferenceShape) {
  for (bool plain : {false, true}) {
    const KernelChoice kernels(plain);
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
          if (plain) EXPECT_FALSE(mf.wide_kernels());
        }
      }
    }
  }
}

// The windows' ends go through the band series (direct_share() == 0: no silent fallback to
// term-by-term sums) for short and long windows, slow and fast heat, several contours, and
// contour seams; each must agree with the explicit matrix within epsilon of its scale.
TEST(MatrixFree, WindowEndSeriesAgreesForEveryWindowWidth) {
  auto check = [](const ContourSet& contours, const Measures& mu, const HeatLaplacianOptions& o, const std::string& what) {
    const ContourOperator op = heat_laplacian(contours, mu, o);
    const MatrixFreeLaplacian mf(contours, mu, o, 1e-10);
    EXPECT_EQ(mf.direct_share(), 0.0) << what;
    EXPECT_GE(mf.band_order(), 1) << what;
    EXPECT_LE(mf.band_order(), 12) << what;  // |2 alpha beta| <= 1/4 needs ~8 terms at 1e-11
    const Eigen::VectorXd g = Eigen::VectorXd::Random(op.rows());
    const double scale = op.L.diagonal().cwiseAbs().maxCoeff() * g.cwiseAbs().maxCoeff();
    EXPECT_LE((mf * g - op.L * g).cwiseAbs().maxCoeff(), 1e-10 * scale) << what;
  };
  for (bool plain : {false, true}) {
    const KernelChoice kernels(plain);
    const Pipeline flower = pipeline(AccFlower(), 0.005);
    for (double k : {1.0, 2.0, 3.0, 10.0})
      for (double c_t : {0.01, 0.3}) {
        HeatLaplacianOptions o;
        o.k = k;
        o.c_t = c_t;
        o.length_scale = 1.0;  // t = c_t h^(2/3): the window widths this test was written for
        check(flower.contours, flower.mu, o, "accflower k " + std::to_string(k) + " c_t " + std::to_string(c_t));
      }
    // Three contours, with seams.
    const Pipeline three = annulus_and_disc();
    ASSERT_EQ(three.contours.contours.size(), 3u);
    for (auto placement : {Placement::Pointels, Placement::Linels}) {
      HeatLaplacianOptions o;
      o.placement = placement;
      check(three.contours, three.mu, o, "annulus and disc");
    }
  }
}

// Both builds of the loops compute the same sums in the same order; they differ only where
// the wide one fuses a multiply and an add (one rounding instead of two): a few units in the
// last place of the terms, so 1e-13 of the operator's scale (measured 5e-14 at h = 1e-4).
TEST(MatrixFree, PlainAndWideKernelsAgree) {
  const Pipeline s = pipeline(Flower(), 0.002);
  const MatrixFreeLaplacian mf(s.contours, s.mu);
  const Eigen::VectorXd g = Eigen::VectorXd::Random(mf.rows());
  Eigen::VectorXd y[2];
  for (bool plain : {false, true}) {
    const KernelChoice kernels(plain);
    y[plain] = MatrixFreeLaplacian(s.contours, s.mu) * g;
  }
  const double scale = mf.diagonal().cwiseAbs().maxCoeff() * g.cwiseAbs().maxCoeff();
  EXPECT_LE((y[0] - y[1]).cwiseAbs().maxCoeff(), 1e-13 * scale);
}

// The plan sits behind a pointer (issue 21): a copy is deep, with scratch of its own, so that
// products on an operator and on its copy may run at the same time (shared scratch would mix
// them); both give the original's bits. A moved-to operator works as the original did.
TEST(MatrixFree, CopiesAreDeepAndMovesKeepThePlan) {
  const Pipeline s = pipeline(Flower(), 0.01);
  const MatrixFreeLaplacian original(s.contours, s.mu);
  const Eigen::VectorXd g = Eigen::VectorXd::Random(original.rows()), h = Eigen::VectorXd::Random(original.rows());
  const Eigen::VectorXd expected_g = original * g, expected_h = original * h;
  const MatrixFreeLaplacian copy = original;
  Eigen::VectorXd from_original[20], from_copy[20];
  std::thread other([&] {
    for (auto& y : from_copy) y = copy * h;
  });
  for (auto& y : from_original) y = original * g;
  other.join();
  for (int k = 0; k < 20; ++k) {
    EXPECT_EQ(from_original[k], expected_g) << k;
    EXPECT_EQ(from_copy[k], expected_h) << k;
  }
  MatrixFreeLaplacian moved = MatrixFreeLaplacian(s.contours, s.mu);
  EXPECT_EQ(moved * g, expected_g);
  EXPECT_EQ(moved.t(), original.t());
  EXPECT_EQ(moved.mass(), original.mass());
}

// Windows about one element wide (k = 0.5): boxes would outnumber the elements, so the
// contour is summed term by term, and the result is still the explicit matrix's.
TEST(MatrixFree, ContoursWithMoreBoxesThanElementsAreSummedDirectly) {
  const Pipeline s = pipeline(Flower(), 0.05);
  HeatLaplacianOptions o;
  o.k = 0.5;
  const ContourOperator op = heat_laplacian(s.contours, s.mu, o);
  const MatrixFreeLaplacian mf(s.contours, s.mu, o);
  EXPECT_EQ(mf.direct_share(), 1.0);
  const Eigen::VectorXd g = Eigen::VectorXd::Random(op.rows());
  EXPECT_LE((mf * g - op.L * g).cwiseAbs().maxCoeff(), 1e-10 * op.L.diagonal().cwiseAbs().maxCoeff());
}

// Issue 15, item 2: the operator's memory followed P / sqrt(t), not N (3.6 GB for N = 76 at
// t = 1e-13, 11.4 GB at 1e-14, whatever the memory limit). With a tiny t, or a huge k, it is
// now a few bytes per row, within a memory limit of 1 MB, and still equals the explicit one.
// Above the limit it is refused with its estimate, before allocating.
TEST(MatrixFree, MemoryFollowsTheRowsWhateverTAndK) {
  const Pipeline s = pipeline(Circle(), 0.1);
  for (auto [t, k] : {std::pair{1e-13, 6.0}, {1e-14, 6.0}, {1e-16, 1e9}, {1e-6, 6.0}, {1e-200, 1e300}}) {
    HeatLaplacianOptions o;
    o.t = t;
    o.k = k;
    o.memory_limit_bytes = 1e6;
    const MatrixFreeLaplacian mf(s.contours, s.mu, o);
    EXPECT_EQ(mf.direct_share(), 1.0) << "t = " << t;
    const ContourOperator op = heat_laplacian(s.contours, s.mu, o);
    const Eigen::VectorXd g = Eigen::VectorXd::Random(op.rows());
    EXPECT_LE((mf * g - op.L * g).cwiseAbs().maxCoeff(), 1e-10 * std::max(1.0, op.L.diagonal().cwiseAbs().maxCoeff())) << "t = " << t;
  }
  const Pipeline fine = pipeline(Flower(), 0.002);
  HeatLaplacianOptions o;
  o.memory_limit_bytes = 1e5;
  try {
    MatrixFreeLaplacian(fine.contours, fine.mu, o);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("above the memory limit of 0.0001 GB; raise memory_limit_bytes or use a coarser h"),
              std::string::npos) << e.what();
  }
  // A t whose prefactor overflows is refused by both operators.
  o.t = 1e-300;
  o.memory_limit_bytes = 1e9;
  EXPECT_THROW(MatrixFreeLaplacian(fine.contours, fine.mu, o), Error);
  EXPECT_THROW(heat_laplacian(fine.contours, fine.mu, o), Error);
}

// Every row is computed by one thread from per-box sums in a fixed order: the product must
// not depend on the number of threads, bit for bit (also with boxes summed directly, k = 0.5).
TEST(MatrixFree, BitwiseIdenticalForOneAndTwoThreads) {
  const Pipeline s = pipeline(Flower(), 0.002);
  for (double k : {6.0, 0.5}) {
    HeatLaplacianOptions o;
    o.k = k;
    omp_set_num_threads(1);
    const MatrixFreeLaplacian one(s.contours, s.mu, o);
    const Eigen::VectorXd g = Eigen::VectorXd::Random(one.rows());
    const Eigen::VectorXd y1 = one * g;
    omp_set_num_threads(2);
    const MatrixFreeLaplacian two(s.contours, s.mu, o);
    const Eigen::VectorXd y2 = two * g;
    EXPECT_EQ(std::memcmp(y1.data(), y2.data(), sizeof(double) * y1.size()), 0) << "k " << k;
    EXPECT_EQ(std::memcmp(one.diagonal().data(), two.diagonal().data(), sizeof(double) * y1.size()), 0) << "k " << k;
  }
}

// A block's columns are multiplied side by side, each on one thread with scratch of its own:
// bit for bit the column-by-column products, on the flower and on three contours (an annulus
// and a disc), with boxes summed directly too (k = 0.5).
TEST(MatrixFree, BlockProductEqualsTheColumnByColumnProducts) {
  const int threads = omp_get_max_threads();
  omp_set_num_threads(2);
  for (const Pipeline& s : {pipeline(Flower(), 0.002), annulus_and_disc()}) {
    for (double k : {6.0, 0.5}) {
      HeatLaplacianOptions o;
      o.k = k;
      const MatrixFreeLaplacian mf(s.contours, s.mu, o);
      for (std::size_t c = 0; c + 1 < mf.row_offset().size(); ++c) {
        const Eigen::Index n = mf.row_offset()[c + 1] - mf.row_offset()[c];
        const Eigen::MatrixXd x = Eigen::MatrixXd::Random(n, 5);
        Eigen::MatrixXd block, columns(n, 5);
        mf.apply_contour_block(c, x, block);
        for (Eigen::Index j = 0; j < 5; ++j) mf.apply_contour(c, x.col(j).data(), columns.col(j).data());
        ASSERT_EQ(block.rows(), n);
        ASSERT_EQ(block.cols(), 5);
        EXPECT_EQ(std::memcmp(block.data(), columns.data(), sizeof(double) * columns.size()), 0)
            << "contour " << c << " k " << k << ": max difference " << (block - columns).cwiseAbs().maxCoeff();
      }
      Eigen::MatrixXd y;
      EXPECT_THROW(mf.apply_contour_block(0, Eigen::MatrixXd::Zero(3, 2), y), Error);  // wrong row count
      EXPECT_THROW(mf.apply_contour_block(99, Eigen::MatrixXd::Zero(3, 2), y), Error);  // no such contour
    }
  }
  omp_set_num_threads(threads);
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

// The matrix-free eigen-solver (preconditioned LOBPCG) against the factorized one on the
// explicit matrix. Tolerance: the two operators differ by at most eps c (eps = 1e-10, c the
// spectrum's bound 2 max|L_ii|) and each eigenvalue is within its residual bound tolerance * c
// (1e-10 c, Bauer-Fike for symmetric matrices) of the operator's: 3e-10 c leaves a 1.5x margin.
static Spectrum expect_same_spectrum(const ContourSet& contours, const Measures& mu, int count, const std::string& what) {
  const ContourOperator op = heat_laplacian(contours, mu);
  const MatrixFreeLaplacian mf(contours, mu);
  const Spectrum factorized = smallest_eigenpairs(op, {count});
  const Spectrum free = smallest_eigenpairs(mf, {count});
  const double c = 2 * mf.diagonal().cwiseAbs().maxCoeff();
  EXPECT_EQ(free.eigenvalues.size(), count);
  if (free.eigenvalues.size() != count) return free;
  for (int k = 0; k < count; ++k) EXPECT_NEAR(free.eigenvalues[k], factorized.eigenvalues[k], 3e-10 * c) << what << " k " << k;
  const Eigen::MatrixXd gram = free.eigenvectors.transpose() * mf.mass().asDiagonal() * free.eigenvectors;
  EXPECT_LE((gram - Eigen::MatrixXd::Identity(count, count)).cwiseAbs().maxCoeff(), 1e-8) << what;
  return free;
}

TEST(MatrixFree, LobpcgMatchesTheFactorizedSolverInIterationsIndependentOfH) {
  Flower flower;
  for (double h : {0.01, 0.002}) {
    const Pipeline s = pipeline(flower, h);
    const Spectrum free = expect_same_spectrum(s.contours, s.mu, 10, "flower h " + std::to_string(h));
    // The arclength preconditioner makes the iteration count independent of h (12 and 10
    // measured); Lanczos needs 412 and about 1000 products here, growing like h^(-1/3).
    EXPECT_LE(free.iterations, 20) << "h " << h;
    EXPECT_LE(free.operations, 15 * 21) << "h " << h;  // one block of 15 per iteration
  }
}

TEST(MatrixFree, EigenSolverReportsProgressAndRespectsTheMemoryLimit) {
  const Pipeline s = pipeline(Flower(), 0.01);  // N = 2108
  const MatrixFreeLaplacian mf(s.contours, s.mu);
  SpectrumOptions o;
  std::vector<double> residuals;
  o.progress = [&](int iteration, double r) {
    EXPECT_EQ(iteration, static_cast<int>(residuals.size()));
    residuals.push_back(r);
  };
  const Spectrum lobpcg = smallest_eigenpairs(mf, o);
  ASSERT_EQ(static_cast<int>(residuals.size()), lobpcg.iterations + 1);
  EXPECT_GT(residuals.front(), 1e3);  // a random start is far from converged
  EXPECT_LE(residuals.back(), 1.0);   // and the last one met the tolerance
  // LOBPCG would hold 16 x 2108 x 15 doubles (4.0 MB), Lanczos 2 x 2108 x 50 (1.7 MB): a limit
  // between the two takes the Lanczos fallback, which must find the same eigenvalues (both
  // within 1e-10 c of the operator's); a limit below both is refused, naming the limit.
  o.progress = nullptr;
  o.memory_limit_bytes = 2.5e6;
  const Spectrum lanczos = smallest_eigenpairs(mf, o);
  const double c = 2 * mf.diagonal().cwiseAbs().maxCoeff();
  for (int k = 0; k < o.count; ++k) EXPECT_NEAR(lanczos.eigenvalues[k], lobpcg.eigenvalues[k], 2e-10 * c) << k;
  EXPECT_GT(lanczos.operations, lobpcg.operations);  // 412 against 195: Lanczos did run
  o.memory_limit_bytes = 1e6;
  try {
    smallest_eigenpairs(mf, o);
    ADD_FAILURE() << "no error below the memory limit";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("above the memory limit"), std::string::npos) << e.what();
  }
}

TEST(MatrixFree, LobpcgOnSeveralContoursOfDifferentLengths) {
  // The annulus has two zero eigenvalues (outer contour and hole), then each contour's own
  // modes; with the disc, three contours and three zero eigenvalues.
  const Pipeline three = annulus_and_disc();
  ASSERT_EQ(three.contours.contours.size(), 3u);
  expect_same_spectrum(three.contours, three.mu, 12, "annulus and disc");
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

// The eigen solver's preconditioner solves a cyclic tridiagonal system (lib/cyclic_tridiagonal.hpp):
// against a dense LU of the same matrix, at the sizes where the corner entries meet the last
// row's fill (3, 4) and larger. The matrices are diagonally dominant (condition number below
// about 10), so a backward-stable solve leaves x within about 1e-15 n of the dense one: 1e-12
// relative allows for that with room, and a wrong fill entry or pivot is off by O(1).
TEST(CyclicTridiagonal, SolvesLikeADenseFactorization) {
  std::uint64_t state = 12345;
  auto uniform = [&state] {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(state >> 11) * 0x1.0p-53;
  };
  for (Eigen::Index n : {3, 4, 5, 9, 200}) {
    Eigen::VectorXd coupling(n), diagonal(n), b(n);
    for (Eigen::Index i = 0; i < n; ++i) coupling[i] = -(0.1 + uniform());
    for (Eigen::Index i = 0; i < n; ++i)
      diagonal[i] = std::abs(coupling[i]) + std::abs(coupling[(i + n - 1) % n]) + 0.05 + uniform();
    for (Eigen::Index i = 0; i < n; ++i) b[i] = uniform() - 0.5;
    Eigen::MatrixXd dense = diagonal.asDiagonal();
    for (Eigen::Index i = 0; i < n; ++i) {
      dense(i, (i + 1) % n) += coupling[i];
      dense((i + 1) % n, i) += coupling[i];
    }
    const Eigen::VectorXd expected = dense.partialPivLu().solve(b);
    const detail::CyclicTridiagonalLDLT factor(diagonal, coupling);
    Eigen::VectorXd x = b;
    factor.solve_in_place(x.data());
    EXPECT_LE((x - expected).cwiseAbs().maxCoeff(), 1e-12 * expected.cwiseAbs().maxCoeff()) << "n " << n;
  }
}

TEST(CyclicTridiagonal, RefusesWhatItCannotFactorize) {
  const Eigen::VectorXd two = Eigen::VectorXd::Ones(2);
  EXPECT_THROW(detail::CyclicTridiagonalLDLT(two, two), Error);  // n < 3
  EXPECT_THROW(detail::CyclicTridiagonalLDLT(Eigen::VectorXd::Ones(4), Eigen::VectorXd::Ones(3)), Error);
  // 2 on the diagonal, -1 around the loop: the loop's Laplacian, singular (constants), whose
  // last pivot is 0 up to rounding.
  for (Eigen::Index n : {6, 1001})
    EXPECT_THROW(detail::CyclicTridiagonalLDLT(Eigen::VectorXd::Constant(n, 2.0), Eigen::VectorXd::Constant(n, -1.0)),
                 Error) << n;
  EXPECT_THROW(detail::CyclicTridiagonalLDLT(-Eigen::VectorXd::Ones(5), Eigen::VectorXd::Zero(5)), Error);
}
