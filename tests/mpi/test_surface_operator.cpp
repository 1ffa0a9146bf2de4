// mpi/surface_operator.hpp, run by mpirun on 1, 2 and 3 ranks (ctest): the distributed operator
// equals the one-machine one row for row, bit for bit (the same columns, the same values, the same
// areas and heat times), whatever the number of ranks; its eigenvalues equal the one-machine
// spectrum's with each SLEPc solver. The volume is long along z, so that ranks hold different
// slabs, with structures that cross slab boundaries, a hollow shell (two surfaces: the slabs must
// not join its inside to its outside), and a speck for --min-size.
#include "digilap/mpi/heat_flow.hpp"
#include "digilap/mpi/surface_operator.hpp"

#include "digilap/core/error.hpp"
#include "digilap/core/spectrum.hpp"
#include "digilap/surface/heat_laplacian.hpp"
#include "digilap/surface/volume.hpp"

#include <gtest/gtest.h>
#include <slepcsys.h>

#include <cmath>
#include <fstream>
#include <map>
#include <tuple>

using namespace digilap;
using namespace digilap::surface;

namespace {

int rank_of(MPI_Comm comm = PETSC_COMM_WORLD) {
  int r = 0;
  MPI_Comm_rank(comm, &r);
  return r;
}

// A uint8 .npy volume (C order) of nx x ny x nz voxels, inside(i, j, k), written by rank 0.
template <class Inside>
std::string write_volume(const std::string& name, int nx, int ny, int nz, Inside inside) {
  const std::string path = ::testing::TempDir() + "/" + name + ".npy";
  if (rank_of() == 0) {
    std::string data(static_cast<std::size_t>(nx * ny * nz), '\0');
    for (int k = 0; k < nz; ++k)
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) data[static_cast<std::size_t>((k * ny + j) * nx + i)] = inside(i, j, k);
    std::string dict = "{'descr': '|u1', 'fortran_order': False, 'shape': (" + std::to_string(nz) + ", " + std::to_string(ny) + ", " +
                       std::to_string(nx) + "), }";
    dict.append((64 - (10 + dict.size() + 1) % 64) % 64, ' ');
    dict += '\n';
    std::ofstream(path, std::ios::binary) << std::string("\x93NUMPY\x01\x00", 8) << static_cast<char>(dict.size() & 0xff)
                                          << static_cast<char>(dict.size() >> 8) << dict << data;
  }
  MPI_Barrier(PETSC_COMM_WORLD);
  return path;
}

// The volume (32 x 32 x 128 voxels).
std::string sample_volume() {
  return write_volume("digilap_mpi_sample", 32, 32, 128, [](int i, int j, int k) {
    const double x = i, y = j, z = k;
    const double ring = std::hypot(y - 18, z - 24) - 9;  // torus around the x axis
    const bool torus = ring * ring + (x - 18) * (x - 18) < 3.5 * 3.5;
    const double shell_r = std::sqrt((x - 20) * (x - 20) + (y - 20) * (y - 20) + (z - 64) * (z - 64));
    const bool shell = shell_r < 9 && shell_r > 5;
    const double s = std::clamp((z - 30) / 85, 0.0, 1.0);  // capsule from (4, 4, 30) to (4, 28, 115)
    const bool capsule = std::hypot(x - 4, y - (4 + 24 * s), z - (30 + 85 * s)) < 2.5;
    const bool ball = std::sqrt((x - 18) * (x - 18) + (y - 18) * (y - 18) + (z - 100) * (z - 100)) < 6;
    const bool speck = i >= 28 && i < 30 && j >= 4 && j < 6 && k >= 120 && k < 122;
    return torus || shell || capsule || ball || speck;
  });
}

// The one-machine pipeline of digilap-spectrum --volume: surfels, II normals, areas, operator.
struct Serial {
  SurfelSet surfels;
  SurfelMeasures measures;
  SurfaceOperator op;
  std::map<std::tuple<int, int, int, int, int>, Eigen::Index> index;
};
std::tuple<int, int, int, int, int> key(const Surfel& f) { return {f.voxel.x(), f.voxel.y(), f.voxel.z(), f.axis, f.sign}; }
Serial serial(const std::string& path, const mpi::DistributedSurfaceOptions& o) {
  Serial s;
  const VoxelSet voxels = read_volume(path, o.volume);
  s.surfels = filter_surfels(voxels, extract_surfels(voxels), {o.min_surfels, o.largest_only}).surfels;
  s.measures = measures(s.surfels, ii_normals(voxels, s.surfels, {o.k_R, o.length_scale, o.length_quantile}));
  s.op = heat_laplacian(s.surfels, s.measures, o.op);
  for (std::size_t q = 0; q < s.surfels.size(); ++q) s.index[key(s.surfels.surfels[q])] = static_cast<Eigen::Index>(q);
  return s;
}

// Every rank's surfels, in global row order.
std::vector<Surfel> all_surfels(const mpi::DistributedSurfaceOperator& d) {
  std::vector<int> mine;
  for (const Surfel& f : d.surfels) mine.insert(mine.end(), {f.voxel.x(), f.voxel.y(), f.voxel.z(), f.axis, f.sign});
  int size = 1;
  MPI_Comm_size(d.comm, &size);
  std::vector<int> counts(static_cast<std::size_t>(size)), displs(static_cast<std::size_t>(size), 0);
  int n = static_cast<int>(mine.size());
  MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, d.comm);
  for (int q = 1; q < size; ++q) displs[q] = displs[q - 1] + counts[q - 1];
  std::vector<int> flat(static_cast<std::size_t>(displs.back() + counts.back()));
  MPI_Allgatherv(mine.data(), n, MPI_INT, flat.data(), counts.data(), displs.data(), MPI_INT, d.comm);
  std::vector<Surfel> out;
  for (std::size_t q = 0; q < flat.size(); q += 5)
    out.push_back({{flat[q], flat[q + 1], flat[q + 2]}, static_cast<std::int8_t>(flat[q + 3]), static_cast<std::int8_t>(flat[q + 4])});
  return out;
}

// Each owned row of `distributed` holds exactly the entries of the serial row of the same surfel
// (tolerance 0), or the same columns with values within `tolerance` of the row's largest.
void expect_same_rows(Mat distributed, const SparseMatrix& serial_matrix, const mpi::DistributedSurfaceOperator& d, const Serial& s,
                      const std::vector<Surfel>& global, const char* name, double tolerance = 0) {
  int mismatches = 0;
  for (std::int64_t g = d.row_begin; g < d.row_end && mismatches < 5; ++g) {
    const Eigen::Index row = s.index.at(key(global[static_cast<std::size_t>(g)]));
    std::map<Eigen::Index, double> expected;
    for (SparseMatrix::InnerIterator it(serial_matrix, row); it; ++it) expected[it.col()] = it.value();
    PetscInt ncols;
    const PetscInt* cols;
    const PetscScalar* values;
    MatGetRow(distributed, static_cast<PetscInt>(g), &ncols, &cols, &values);
    std::map<Eigen::Index, double> got;
    for (PetscInt c = 0; c < ncols; ++c) got[s.index.at(key(global[static_cast<std::size_t>(cols[c])]))] = values[c];
    MatRestoreRow(distributed, static_cast<PetscInt>(g), &ncols, &cols, &values);
    bool same = got == expected;  // exact: the same doubles, bit for bit
    if (!same && tolerance > 0 && got.size() == expected.size()) {
      double largest = 0, worst = 0;
      for (const auto& [col, value] : expected) largest = std::max(largest, std::abs(value));
      same = true;
      for (const auto& [col, value] : expected) {
        const auto at = got.find(col);
        if (at == got.end()) same = false;
        else worst = std::max(worst, std::abs(at->second - value));
      }
      same = same && worst <= tolerance * largest;
    }
    if (!same) {
      ++mismatches;
      ADD_FAILURE() << name << " row of surfel (" << global[static_cast<std::size_t>(g)].voxel.transpose() << ") differs: "
                    << got.size() << " entries against " << expected.size();
    }
  }
}

struct Case {
  const char* name;
  std::size_t min_surfels;
  bool largest;
  double length_scale;
};

}  // namespace

TEST(Mpi, DistributedOperatorEqualsTheSerialOneRowForRow) {
  const std::string path = sample_volume();
  for (const Case& c : {Case{"measured l, every surface", 0, false, 0.0}, Case{"min size 50 (the speck dropped)", 50, false, 0.0},
                        Case{"largest only", 0, true, 0.0}, Case{"l given", 0, false, 5.0}}) {
    SCOPED_TRACE(c.name);
    mpi::DistributedSurfaceOptions o;
    o.min_surfels = c.min_surfels, o.largest_only = c.largest, o.length_scale = c.length_scale;
    o.op.surface_kernel = SurfaceKernel::Chord;  // bit for bit (the intrinsic kernel: below)
    const Serial s = serial(path, o);
    const mpi::DistributedSurfaceOperator d = mpi::distributed_surface_operator(PETSC_COMM_WORLD, path, o);
    ASSERT_EQ(d.size, static_cast<std::int64_t>(s.surfels.size()));
    EXPECT_EQ(d.length_scale, s.measures.length_scale);
    EXPECT_EQ(d.surface_t, s.op.part_t);  // the same surfaces, in the same order, with the same t
    const std::vector<Surfel> global = all_surfels(d);
    ASSERT_EQ(global.size(), s.surfels.size());
    for (std::int64_t g = d.row_begin; g < d.row_end; ++g)
      ASSERT_EQ(d.mu[g - d.row_begin], s.measures.mu[s.index.at(key(global[static_cast<std::size_t>(g)]))]) << "area of row " << g;
    expect_same_rows(d.L, s.op.L, d, s, global, "L");
    expect_same_rows(d.A, s.op.A, d, s, global, "A");
  }
  {
    // The intrinsic kernel: its curvature factors sum each column's neighbours in the order of
    // the rank's own grid, so rows agree to rounding (1e-13 of the row), not bit for bit; the
    // halo is two cuts deep, or the factors of the halo's columns would miss neighbours and
    // differ by far more.
    SCOPED_TRACE("intrinsic kernel");
    mpi::DistributedSurfaceOptions o;
    o.op.surface_kernel = SurfaceKernel::Intrinsic;
    const Serial s = serial(path, o);
    const mpi::DistributedSurfaceOperator d = mpi::distributed_surface_operator(PETSC_COMM_WORLD, path, o);
    ASSERT_EQ(d.size, static_cast<std::int64_t>(s.surfels.size()));
    const std::vector<Surfel> global = all_surfels(d);
    expect_same_rows(d.L, s.op.L, d, s, global, "L", 1e-13);
    expect_same_rows(d.A, s.op.A, d, s, global, "A", 1e-13);
  }
  // The measured case has 6 surfaces (torus, the shell's two, capsule, ball, speck): a slab
  // boundary that joined the shell's sides, or split the capsule, would change part_t above.
  mpi::DistributedSurfaceOptions o;
  EXPECT_EQ(mpi::distributed_surface_operator(PETSC_COMM_WORLD, path, o).surface_t.size(), 6u);
}

TEST(Mpi, DistributedEigenvaluesEqualTheSerialSpectrum) {
  const std::string path = sample_volume();
  mpi::DistributedSurfaceOptions o;
  o.min_surfels = 50;  // 5 surfaces: 5 zero eigenvalues, then the smallest nonzero ones
  const Serial s = serial(path, o);
  SpectrumOptions so;
  so.count = 12;
  const Spectrum reference = smallest_eigenpairs(s.op, so);
  const mpi::DistributedSurfaceOperator d = mpi::distributed_surface_operator(PETSC_COMM_WORLD, path, o);
  for (auto solver : {mpi::DistributedEigenSolver::KrylovSchur, mpi::DistributedEigenSolver::Lobpcg, mpi::DistributedEigenSolver::LobpcgAmg,
                      mpi::DistributedEigenSolver::KrylovSchurInvert}) {
    const mpi::DistributedSpectrum ds = mpi::distributed_smallest_eigenpairs(d, 12, solver, 1e-10);
    SCOPED_TRACE(ds.solver);
    ASSERT_EQ(ds.eigenvalues.size(), 12);
    for (int k = 0; k < 12; ++k) {
      // Both solve to ~1e-10 relative residuals; eigenvalues converge as the residual squared,
      // so 1e-7 of the largest leaves room for the two solvers' stopping rules.
      EXPECT_NEAR(ds.eigenvalues[k], reference.eigenvalues[k], 1e-7 * reference.eigenvalues[11]) << "k = " << k;
      EXPECT_NEAR(ds.laplace_beltrami[k], reference.laplace_beltrami[k], 1e-7 * reference.laplace_beltrami[11]) << "k = " << k;
    }
    // M-orthonormal eigenvectors: x_k^T M x_k = 1 over the ranks.
    for (int k = 0; k < 12; ++k) {
      double norm = (d.mu.array() * ds.eigenvectors.col(k).array().square()).sum();
      MPI_Allreduce(MPI_IN_PLACE, &norm, 1, MPI_DOUBLE, MPI_SUM, d.comm);
      EXPECT_NEAR(norm, 1.0, 1e-8) << "k = " << k;
    }
  }
}

TEST(Mpi, AwkwardSlabsGiveTheSerialRows) {
  // Three layouts the balance must survive (issue 24), each checked row for row and through
  // SLEPc against the one-machine spectrum:
  // - a 2 x 2 x 2 cube: 24 surfels on 2 planes, so on 3 ranks one rank owns no surfel at all;
  // - a disc 5 planes thick in a 7-plane volume: every rank's slab is far thinner than the
  //   halo (about 11 planes), so each reads the whole volume and keeps only its rows;
  // - a ball in a 29-plane volume: a plane count no number of ranks divides.
  struct Layout {
    const char* name;
    std::string path;
  };
  const Layout layouts[] = {
      {"cube of 8 voxels", write_volume("digilap_mpi_cube", 12, 12, 12, [](int i, int j, int k) {
         return i >= 5 && i < 7 && j >= 5 && j < 7 && k >= 5 && k < 7;
       })},
      {"thin disc", write_volume("digilap_mpi_disc", 30, 30, 7, [](int i, int j, int k) {
         return k >= 1 && k < 6 && std::hypot(i - 14.5, j - 14.5) < 10;
       })},
      {"ball, 29 planes", write_volume("digilap_mpi_ball29", 20, 20, 29, [](int i, int j, int k) {
         return std::sqrt((i - 9.5) * (i - 9.5) + (j - 9.5) * (j - 9.5) + (k - 14.0) * (k - 14.0)) < 7;
       })},
  };
  int ranks = 1;
  MPI_Comm_size(PETSC_COMM_WORLD, &ranks);
  for (const Layout& layout : layouts) {
    SCOPED_TRACE(layout.name);
    mpi::DistributedSurfaceOptions o;
    o.op.surface_kernel = SurfaceKernel::Chord;  // bit for bit
    const Serial s = serial(layout.path, o);
    const mpi::DistributedSurfaceOperator d = mpi::distributed_surface_operator(PETSC_COMM_WORLD, layout.path, o);
    ASSERT_EQ(d.size, static_cast<std::int64_t>(s.surfels.size()));
    const std::vector<Surfel> global = all_surfels(d);
    expect_same_rows(d.L, s.op.L, d, s, global, "L");
    expect_same_rows(d.A, s.op.A, d, s, global, "A");
    std::int64_t fewest = d.row_end - d.row_begin, thinnest = d.plane_end - d.plane_begin;
    MPI_Allreduce(MPI_IN_PLACE, &fewest, 1, MPI_INT64_T, MPI_MIN, PETSC_COMM_WORLD);
    MPI_Allreduce(MPI_IN_PLACE, &thinnest, 1, MPI_INT64_T, MPI_MIN, PETSC_COMM_WORLD);
    if (ranks == 3 && layout.path.find("cube") != std::string::npos) EXPECT_EQ(fewest, 0) << "no rank was left empty";
    if (ranks >= 2 && layout.path.find("disc") != std::string::npos) EXPECT_LT(thinnest, d.halo_planes) << "the slabs were not thin";
    SpectrumOptions so;
    so.count = 6;
    const Spectrum reference = smallest_eigenpairs(s.op, so);
    const mpi::DistributedSpectrum ds = mpi::distributed_smallest_eigenpairs(d, 6, mpi::DistributedEigenSolver::KrylovSchur, 1e-10);
    ASSERT_EQ(ds.eigenvalues.size(), 6);
    for (int k = 0; k < 6; ++k)  // as in DistributedEigenvaluesEqualTheSerialSpectrum
      EXPECT_NEAR(ds.eigenvalues[k], reference.eigenvalues[k], 1e-7 * reference.eigenvalues[5]) << "k = " << k;
  }
}

TEST(Mpi, DistributedHeatFlowFollowsTheSerialOne) {
  const std::string path = sample_volume();
  mpi::DistributedSurfaceOptions o;  // every surface, the speck's zero-area surfels included
  const Serial s = serial(path, o);
  const mpi::DistributedSurfaceOperator d = mpi::distributed_surface_operator(PETSC_COMM_WORLD, path, o);
  const std::vector<Surfel> global = all_surfels(d);
  // u0: a smooth function and a spike, the same on every surfel whichever rank holds it.
  auto u0_of = [](const Surfel& f) { return std::sin(0.3 * f.voxel.x()) + 0.01 * f.voxel.z() + (f.voxel.y() == 18 ? 1.0 : 0.0); };
  Eigen::VectorXd u0_serial(static_cast<Eigen::Index>(s.surfels.size())), u0(d.row_end - d.row_begin);
  for (std::size_t q = 0; q < s.surfels.size(); ++q) u0_serial[static_cast<Eigen::Index>(q)] = u0_of(s.surfels.surfels[q]);
  for (std::int64_t g = d.row_begin; g < d.row_end; ++g) u0[g - d.row_begin] = u0_of(global[static_cast<std::size_t>(g)]);
  for (auto scheme : {TimeScheme::CrankNicolson, TimeScheme::ImplicitEuler})
    for (auto pc : {mpi::DistributedPreconditioner::Jacobi, mpi::DistributedPreconditioner::Amg}) {
      const double dt = 3 * d.t();
      const HeatFlow serial_flow(s.op, dt, scheme, HeatSolver::ConjugateGradient);
      const Eigen::VectorXd want = serial_flow.advance(u0_serial, 4);
      const mpi::DistributedHeatFlow flow(d, dt, scheme, pc);
      const Eigen::VectorXd got = flow.advance(u0, 4);
      double worst = 0, moved = 0, heat = 0, heat0 = 0;
      for (std::int64_t g = d.row_begin; g < d.row_end; ++g) {
        const Eigen::Index q = s.index.at(key(global[static_cast<std::size_t>(g)]));
        worst = std::max(worst, std::abs(got[g - d.row_begin] - want[q]));
        moved = std::max(moved, std::abs(got[g - d.row_begin] - u0[g - d.row_begin]));
        heat += d.mu[g - d.row_begin] * got[g - d.row_begin], heat0 += d.mu[g - d.row_begin] * u0[g - d.row_begin];
      }
      MPI_Allreduce(MPI_IN_PLACE, &worst, 1, MPI_DOUBLE, MPI_MAX, d.comm);
      MPI_Allreduce(MPI_IN_PLACE, &moved, 1, MPI_DOUBLE, MPI_MAX, d.comm);
      MPI_Allreduce(MPI_IN_PLACE, &heat, 1, MPI_DOUBLE, MPI_SUM, d.comm);
      MPI_Allreduce(MPI_IN_PLACE, &heat0, 1, MPI_DOUBLE, MPI_SUM, d.comm);
      // Both solve each step to 1e-12 relative residual from the same guess; the system's
      // condition number (about 1 + dt/t, here 4) keeps the two solutions within 1e-10 of
      // |u| ~ 1 after 4 steps. The heat is conserved to rounding by both.
      EXPECT_LT(worst, 1e-10) << "scheme " << static_cast<int>(scheme) << ", preconditioner " << static_cast<int>(pc);
      EXPECT_NEAR(heat, heat0, 1e-12 * std::abs(heat0) * 100);
      EXPECT_GT(moved, 0.1) << "the heat did not flow";  // the spike spreads
      EXPECT_GT(flow.last_iterations(), 0);
    }
  EXPECT_THROW(mpi::DistributedHeatFlow(d, -1.0), digilap::Error);
}

TEST(Mpi, BadInputIsRefusedOnEveryRank) {
  mpi::DistributedSurfaceOptions o;
  o.volume.label = 77;  // no such label
  const std::string path = sample_volume();
  try {
    mpi::distributed_surface_operator(PETSC_COMM_WORLD, path, o);
    ADD_FAILURE() << "no error";
  } catch (const digilap::Error& e) {
    EXPECT_NE(std::string(e.what()).find("no voxel has the label 77"), std::string::npos) << e.what();
  }
  try {
    mpi::distributed_surface_operator(PETSC_COMM_WORLD, "/nonexistent.npy", {});
    ADD_FAILURE() << "no error";
  } catch (const digilap::Error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot open"), std::string::npos) << e.what();
  }
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  SlepcInitialize(&argc, &argv, nullptr, nullptr);
  if (rank_of() != 0) delete ::testing::UnitTest::GetInstance()->listeners().Release(
      ::testing::UnitTest::GetInstance()->listeners().default_result_printer());
  int failed = RUN_ALL_TESTS();
  MPI_Allreduce(MPI_IN_PLACE, &failed, 1, MPI_INT, MPI_MAX, PETSC_COMM_WORLD);
  SlepcFinalize();
  return failed;
}
