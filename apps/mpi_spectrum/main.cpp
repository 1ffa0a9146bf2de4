// digilap-mpi-spectrum: the spectrum of a segmented volume's surfaces across MPI ranks
// (mpirun -n P), on PETSc and SLEPc (issue 24). An app of its own rather than
// `digilap-spectrum --mpi`: the one-machine apps then never link MPI, run without mpirun and
// build where PETSc is absent; this one is built with DIGILAP_MPI.
//
// Rank 0 writes eigenvalues.csv (the same columns as digilap-spectrum) and the surfels with
// their eigenvectors: one PLY gathered on rank 0 when N <= --gather-limit, else one PLY per rank
// (surfels.rank-0000.ply ...) and surfels_index.csv saying which rows and planes each holds.
// --save-operator writes L, A and mu in PETSc's binary format (MatLoad / VecLoad, petsc4py).
#include "../common/options.hpp"
#include "../common/progress.hpp"

#include "digilap/core/error.hpp"
#include "digilap/mpi/surface_operator.hpp"
#include "digilap/surface/ply.hpp"

#include <CLI/CLI.hpp>
#include <slepcsys.h>

#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

using namespace digilap;

namespace {

struct AppOptions {
  std::string volume;
  mpi::DistributedSurfaceOptions surface;
  int count = 10;
  AppOptions() { surface.min_surfels = 8; }  // digilap-spectrum's --min-size default
  std::string solver = "krylov-schur";  // the fastest measured (docs/distributed.md)
  double tolerance = 1e-9;
  std::string out_dir = "out/mpi-spectrum";
  std::int64_t gather_limit = 2'000'000;
  bool save_operator = false;
  bool quiet = false;
};

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Peak resident memory of this process, in bytes (Linux reports kilobytes).
double peak_rss_bytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) * 1024.0;
}

void petsc_call(PetscErrorCode code, const char* what) {
  if (code != 0) throw Error(std::string("PETSc: ") + what + " failed (error code " + std::to_string(code) + ")");
}

void save_binary(MPI_Comm comm, const std::string& path, Mat matrix, Vec vector) {
  PetscViewer viewer;
  petsc_call(PetscViewerBinaryOpen(comm, path.c_str(), FILE_MODE_WRITE, &viewer), "PetscViewerBinaryOpen");
  const PetscErrorCode code = matrix ? MatView(matrix, viewer) : VecView(vector, viewer);
  PetscViewerDestroy(&viewer);
  petsc_call(code, "MatView/VecView");
}

// Surfels packed as 5 ints (x, y, z, axis, sign) for the gather to rank 0.
std::vector<int> pack(const std::vector<surface::Surfel>& surfels) {
  std::vector<int> out;
  out.reserve(5 * surfels.size());
  for (const auto& s : surfels) out.insert(out.end(), {s.voxel.x(), s.voxel.y(), s.voxel.z(), s.axis, s.sign});
  return out;
}

// The PLY fields: mu and phi_1 ... of the rows given.
std::vector<std::pair<std::string, Eigen::VectorXd>> ply_fields(const Eigen::VectorXd& mu, const Eigen::MatrixXd& vectors) {
  std::vector<std::pair<std::string, Eigen::VectorXd>> fields{{"mu", mu}};
  for (Eigen::Index k = 1; k < vectors.cols(); ++k) fields.emplace_back("phi_" + std::to_string(k), vectors.col(k));
  return fields;
}

// One PLY on rank 0 (every rank sends its rows, in rank order = row order).
std::string save_gathered_ply(const mpi::DistributedSurfaceOperator& op, const mpi::DistributedSpectrum& s, int rank, int ranks,
                              const std::string& out_dir) {
  const int n_local = static_cast<int>(op.surfels.size());
  std::vector<int> counts(static_cast<std::size_t>(ranks)), offsets(static_cast<std::size_t>(ranks));
  MPI_Gather(&n_local, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, op.comm);
  int total = 0;
  for (int r = 0; r < ranks; ++r) offsets[static_cast<std::size_t>(r)] = total, total += counts[static_cast<std::size_t>(r)];
  // Surfels (5 ints each), then one column at a time (mu, then each eigenvector).
  auto scaled = [&](int per) {
    std::vector<int> c(counts), o(offsets);
    for (int r = 0; r < ranks; ++r) c[static_cast<std::size_t>(r)] *= per, o[static_cast<std::size_t>(r)] *= per;
    return std::make_pair(c, o);
  };
  const auto [surfel_counts, surfel_offsets] = scaled(5);
  const std::vector<int> packed = pack(op.surfels);
  std::vector<int> all_packed(rank == 0 ? 5 * static_cast<std::size_t>(total) : 0);
  MPI_Gatherv(packed.data(), 5 * n_local, MPI_INT, all_packed.data(), surfel_counts.data(), surfel_offsets.data(), MPI_INT, 0, op.comm);
  const Eigen::Index columns = s.eigenvectors.cols() + 1;
  Eigen::MatrixXd all(rank == 0 ? total : 0, columns);
  for (Eigen::Index c = 0; c < columns; ++c) {
    const Eigen::VectorXd mine = c == 0 ? Eigen::VectorXd(op.mu) : Eigen::VectorXd(s.eigenvectors.col(c - 1));
    Eigen::VectorXd column(rank == 0 ? total : 0);
    MPI_Gatherv(mine.data(), n_local, MPI_DOUBLE, column.data(), counts.data(), offsets.data(), MPI_DOUBLE, 0, op.comm);
    if (rank == 0) all.col(c) = column;
  }
  if (rank != 0) return "";
  surface::SurfelSet set;
  set.h = op.h;
  set.surfels.resize(static_cast<std::size_t>(total));
  for (std::size_t i = 0; i < set.surfels.size(); ++i) {
    const int* p = &all_packed[5 * i];
    set.surfels[i] = {Eigen::Vector3i(p[0], p[1], p[2]), static_cast<std::int8_t>(p[3]), static_cast<std::int8_t>(p[4])};
  }
  const std::string path = out_dir + "/surfels.ply";
  surface::save_ply(set, ply_fields(all.col(0), all.rightCols(columns - 1)), path);
  return path;
}

// One PLY per rank and an index (rank 0) of their rows and planes.
std::string save_ply_per_rank(const mpi::DistributedSurfaceOperator& op, const mpi::DistributedSpectrum& s, int rank, int ranks,
                              const std::string& out_dir) {
  char name[64];
  std::snprintf(name, sizeof name, "surfels.rank-%04d.ply", rank);
  surface::SurfelSet set;
  set.h = op.h;
  set.surfels = op.surfels;
  // A rank that cannot write must not leave the others waiting in the gather: all agree first.
  std::string failure;
  try {
    surface::save_ply(set, ply_fields(op.mu, s.eigenvectors), out_dir + "/" + name);
  } catch (const std::exception& e) {
    failure = e.what();
  }
  int failed = failure.empty() ? 0 : 1;
  MPI_Allreduce(MPI_IN_PLACE, &failed, 1, MPI_INT, MPI_MAX, op.comm);
  if (failed) throw Error(failure.empty() ? "another rank could not write its PLY" : failure);
  const std::int64_t mine[4] = {op.row_begin, op.row_end, op.plane_begin, op.plane_end};
  std::vector<std::int64_t> all(rank == 0 ? 4 * static_cast<std::size_t>(ranks) : 0);
  MPI_Gather(mine, 4, MPI_INT64_T, all.data(), 4, MPI_INT64_T, 0, op.comm);
  if (rank != 0) return "";
  const std::string index = out_dir + "/surfels_index.csv";
  std::ofstream out(index);
  if (!out) throw Error("cannot write '" + index + "'");
  out << "rank,file,row_begin,row_end,plane_begin,plane_end\n";
  for (int r = 0; r < ranks; ++r) {
    std::snprintf(name, sizeof name, "surfels.rank-%04d.ply", r);
    const std::int64_t* v = &all[4 * static_cast<std::size_t>(r)];
    out << r << ',' << name << ',' << v[0] << ',' << v[1] << ',' << v[2] << ',' << v[3] << '\n';
  }
  return index;
}

int run(const AppOptions& o, int rank, int ranks) {
  const bool talk = rank == 0;
  const auto solver = mpi::distributed_eigen_solver_by_name(o.solver);
  if (o.count < 1) throw Error("--count must be at least 1, got " + std::to_string(o.count));
  if (talk) std::filesystem::create_directories(o.out_dir);
  mpi::DistributedSurfaceOptions surface_options = o.surface;
  surface_options.quiet = o.quiet;
  const auto t0 = std::chrono::steady_clock::now();
  const mpi::DistributedSurfaceOperator op = mpi::distributed_surface_operator(MPI_COMM_WORLD, o.volume, surface_options);
  const double operator_seconds = seconds_since(t0);
  const double operator_rss = peak_rss_bytes();
  if (o.save_operator) {
    save_binary(op.comm, o.out_dir + "/L.petsc", op.L, nullptr);
    save_binary(op.comm, o.out_dir + "/A.petsc", op.A, nullptr);
    save_binary(op.comm, o.out_dir + "/mu.petsc", nullptr, op.mass);
  }
  const auto t1 = std::chrono::steady_clock::now();
  const int wanted = o.count - static_cast<int>(op.surface_t.size());
  std::function<void(int, int)> progress;
  if (talk && !o.quiet)
    progress = [wanted, last = std::chrono::steady_clock::time_point{}, shown = -1](int iteration, int converged) mutable {
      const auto now = std::chrono::steady_clock::now();  // at most 4 lines a second, and each new convergence
      if (converged == shown && now - last < std::chrono::milliseconds(250)) return;
      last = now, shown = converged;
      std::fprintf(stderr, "\reigenpairs: iteration %d, %d of %d converged ", iteration, converged, std::max(wanted, 0));
      std::fflush(stderr);
    };
  const mpi::DistributedSpectrum s = mpi::distributed_smallest_eigenpairs(op, o.count, solver, o.tolerance, progress);
  if (progress) std::fprintf(stderr, "\n");
  const double eigen_seconds = seconds_since(t1);
  // Memory: the largest rank's peak, and the sum.
  double rss[2] = {peak_rss_bytes(), 0};
  rss[1] = rss[0];
  double operator_rss_max = operator_rss;
  MPI_Allreduce(MPI_IN_PLACE, &rss[0], 1, MPI_DOUBLE, MPI_MAX, op.comm);
  MPI_Allreduce(MPI_IN_PLACE, &rss[1], 1, MPI_DOUBLE, MPI_SUM, op.comm);
  MPI_Allreduce(MPI_IN_PLACE, &operator_rss_max, 1, MPI_DOUBLE, MPI_MAX, op.comm);
  PetscInt nnz = 0;
  {
    MatInfo info;
    petsc_call(MatGetInfo(op.L, MAT_GLOBAL_SUM, &info), "MatGetInfo");
    nnz = static_cast<PetscInt>(info.nz_used);
  }
  const std::string ply = op.size <= o.gather_limit ? save_gathered_ply(op, s, rank, ranks, o.out_dir)
                                                    : save_ply_per_rank(op, s, rank, ranks, o.out_dir);
  if (!talk) return 0;
  std::printf("volume %s on %d rank(s): N = %ld surfels in %zu surface(s) (%zu dropped), nnz(L) = %ld\n", o.volume.c_str(), ranks,
              static_cast<long>(op.size), op.surface_t.size(), op.dropped_surfaces, static_cast<long>(nnz));
  std::printf("h = %g, length scale l = %.6g, II radius R = %.6g, t = %.6g; halo %ld planes; %ld surfels of zero area\n", op.h,
              op.length_scale, op.normal_radius, op.t(), static_cast<long>(op.halo_planes), static_cast<long>(op.clamped));
  std::printf("operator %.2f s, eigenpairs %.2f s (%s, %d iterations, tolerance %g); peak memory per rank %.0f MiB "
              "(%.0f MiB after the operator), all ranks %.0f MiB\n",
              operator_seconds, eigen_seconds, s.solver.c_str(), s.iterations, s.tolerance, rss[0] / (1 << 20),
              operator_rss_max / (1 << 20), rss[1] / (1 << 20));
  std::printf("| k | lambda_k | mu_k |\n|---|---|---|\n");
  const std::string values_path = o.out_dir + "/eigenvalues.csv";
  std::ofstream values(values_path);
  if (!values) throw Error("cannot write '" + values_path + "'");
  values << "k,lambda,laplace_beltrami\n";
  values.precision(15);
  for (Eigen::Index k = 0; k < s.eigenvalues.size(); ++k) {
    std::printf("| %ld | %.6f | %.6f |\n", static_cast<long>(k), s.eigenvalues[k], s.laplace_beltrami[k]);
    values << k << ',' << s.eigenvalues[k] << ',' << s.laplace_beltrami[k] << '\n';
  }
  std::printf("\nwrote %s\nwrote %s\n", values_path.c_str(), ply.c_str());
  if (o.save_operator) std::printf("wrote %s/L.petsc, A.petsc, mu.petsc (PETSc binary)\n", o.out_dir.c_str());
  return 0;
}

// PETSc's own options (-eps_type ..., -st_pc_type ..., each with its value) are left to PETSc;
// anything else CLI11 did not know is an error.
void check_extras(const std::vector<std::string>& extras) {
  for (std::size_t i = 0; i < extras.size(); ++i) {
    const std::string& e = extras[i];
    const bool petsc_option = e.size() > 1 && e[0] == '-' && e[1] != '-';
    const bool value_of_previous = i > 0 && extras[i - 1][0] == '-' && extras[i - 1][1] != '-' && e[0] != '-';
    if (!petsc_option && !value_of_previous) throw Error("unknown argument '" + e + "' (see --help)");
  }
}

}  // namespace

int main(int argc, char** argv) {
  AppOptions o;
  CLI::App app{"digilap-mpi-spectrum: the smallest eigenpairs of the Laplace-Beltrami operator of a volume's surfaces,\n"
               "across MPI ranks (mpirun -n P digilap-mpi-spectrum --volume ...). Each rank reads only its slab of planes.\n"
               "Writes <out>/eigenvalues.csv and the surfels with mu and the eigenvectors (surfels.ply, or one PLY per\n"
               "rank and surfels_index.csv above --gather-limit surfels). PETSc and SLEPc options (-eps_monitor,\n"
               "-st_mat_mumps_icntl_14 100, ...) may follow."};
  app.allow_extras();
  app.add_option("--volume", o.volume, "The volume: NIfTI .nii/.nii.gz or .npy (h defaults to the file's spacing)")->required();
  app.add_option("--label", o.surface.volume.label, "The label of the object (default: every voxel >= --threshold)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--threshold", o.surface.volume.threshold, "Without --label: foreground = value >= threshold")->capture_default_str();
  app.add_option("--h", o.surface.volume.h, "Grid step h (default: the file's voxel spacing; 1 for .npy)")->check(CLI::PositiveNumber);
  app.add_option("--min-size", o.surface.min_surfels, "Drop surfaces with fewer surfels")->capture_default_str();
  app.add_flag("--largest", o.surface.largest_only, "Keep the largest surface only");
  app.add_option("--kR", o.surface.k_R, "II radius constant: R = kR h^(1/3) l^(2/3)")->check(CLI::PositiveNumber)->default_str("1 to 1.5 by l / h");
  app.add_option("--length-scale", o.surface.length_scale, "Length scale l (0: measured, as digilap-spectrum does)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--t", o.surface.op.t, "Heat time t (0: ct h^(2/3) l^(4/3))")->check(CLI::NonNegativeNumber)->capture_default_str();
  app.add_option("--ct", o.surface.op.c_t, "Constant of the default heat time")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--k", o.surface.op.k, "Kernel cut at k sqrt(t)")->check(CLI::PositiveNumber)->capture_default_str();
  app::add_surface_kernel_option(app, o.surface.op.surface_kernel);
  app.add_flag("--one-heat-time{false}", o.surface.op.per_contour_time, "One t for all surfaces (default: each surface its own)");
  app.add_option("--memory-limit", o.surface.op.memory_limit_bytes, "Refuse operators estimated larger than this per rank (bytes)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--count", o.count, "Number of eigenpairs (one 0 per surface first)")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--solver", o.solver,
                 "krylov-schur (products only), lobpcg (Jacobi), lobpcg-amg (hypre BoomerAMG) or shift-invert (Krylov-Schur, MUMPS)")
      ->check(CLI::IsMember({"krylov-schur", "lobpcg", "lobpcg-amg", "shift-invert"}))
      ->capture_default_str();
  app.add_option("--tol", o.tolerance, "SLEPc's relative tolerance")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--gather-limit", o.gather_limit, "Gather one PLY on rank 0 up to this many surfels, else one PLY per rank")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_flag("--save-operator", o.save_operator, "Also write L, A and mu in PETSc's binary format");
  app.add_option("--out", o.out_dir, "Output directory")->capture_default_str();
  app.add_flag("--quiet", o.quiet, "No progress on stderr");

  // PETSc reads its options from the whole command line; ours are ignored by it.
  if (SlepcInitialize(&argc, &argv, nullptr, nullptr) != 0) {
    std::fprintf(stderr, "error: SLEPc/PETSc could not be initialized\n");
    return 1;
  }
  int rank = 0, ranks = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  int status = 0;
  try {
    app.parse(argc, argv);
    check_extras(app.remaining());
    status = run(o, rank, ranks);
  } catch (const CLI::ParseError& e) {
    status = rank == 0 ? app.exit(e) : (e.get_exit_code() != 0);
  } catch (const std::exception& e) {
    // Library errors are thrown on every rank with the same message (mpi/collectives.hpp).
    if (rank == 0) std::fprintf(stderr, "error: %s\n", e.what());
    status = 1;
  }
  SlepcFinalize();
  return status;
}
