// Digital surfaces in 3D (SPEC §7, issue 13): reference surfaces, Gauss digitization, surfels,
// II normals, areas, the heat-kernel operator against the exact Laplace-Beltrami operator and
// against an independent NumPy implementation of SPEC §7 (the figures issue 13 quotes).
#include "digilap/error.hpp"
#include "digilap/heat_flow.hpp"
#include "digilap/spectrum.hpp"
#include "digilap/surface/heat_laplacian.hpp"
#include "digilap/surface/ply.hpp"
#include "digilap/surface/volume.hpp"

#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
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
}

// The sphere's spectrum through the 2D solvers (A, mass), and its heat flow. Reference
// (issue 13): at h = 0.05, exact normals, t = 0.1 h^(2/3), l = 1..3 raw within 7.3% of l(l+1),
// within 0.8% after lambda -> -ln(1 - lambda t) / t. The sparse Cholesky of a surface operator
// fills in heavily (60 s at h = 0.05, 0.7 s at h = 0.1), so the test runs at h = 0.1, where we
// measure raw 12.1% and corrected 1.3%: asserted within 15% and 2%, the 3 + 5 + 7 copies
// within 2% of each other.
TEST(Surface, SphereSpectrumAndHeatFlow) {
  Sphere sphere;
  sphere.set_pose(kCentre, Eigen::Matrix3d::Identity());
  const Pipeline p = run(sphere, 0.1, true, 0.1);
  const Spectrum s = smallest_eigenpairs(p.op.A, p.op.mass, {16});
  const Eigen::VectorXd mu = laplace_beltrami_eigenvalues(s.eigenvalues, p.op.t);
  EXPECT_LE(std::abs(s.eigenvalues[0]), 1e-8);
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
std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
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
  EXPECT_DOUBLE_EQ(slab.h(), 1.0 / 24);
}

// Every malformed or unsupported file is refused with the file and the reason.
TEST(Surface, BadNpyVolumesAreRefused) {
  const std::string cube(8, '\1');
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "the file is empty"},
      {"GIF89a....", "not a .npy file"},
      {npy("|u1", false, {2, 2, 2}, "\1\1\1"), "truncated: the data holds 3 of 8 bytes"},
      {npy("|u1", false, {4, 2}, cube), "a volume needs 3 dimensions, got 2"},
      {npy("<f8", false, {1, 1, 1}, std::string(8, '\0')), "dtype '<f8' is not supported"},
      {npy("|u1", false, {2, 0, 2}, ""), "the volume is empty"},
      {npy("|u1", false, {2, 2, 2}, std::string(8, '\0')), "no voxel reaches the threshold"},
      {npy("|u1", false, {100000, 100000, 100000}, ""), "above the limit"},
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
