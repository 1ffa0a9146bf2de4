// Assembly throughput of the heat Laplacian against the memory-bandwidth ceiling.
//
// The ceiling is a plain parallel loop that allocates and writes exactly what the assembly
// writes (L and A: values, column indices and row offsets) with no computation; the ratio
// ceiling_time / assembly_time says how close the assembly is to the memory bandwidth.
// Both are timed in the same process, best of several repetitions, with glibc told to keep
// freed memory (mallopt), so that repetitions reuse pages already mapped: the steady state of
// a program that assembles repeatedly. First-touch page faults cost as much as the assembly
// itself on this machine and vary from run to run with the kernel's memory state; the
// "first run" column shows that cold cost.
#include "digilap/curve/heat_laplacian.hpp"
#include "digilap/surface/heat_laplacian.hpp"

#include <CLI/CLI.hpp>
#include <omp.h>

#include <malloc.h>

#include <chrono>
#include <cstdio>
#include <memory>

using namespace digilap;

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Writes the same bytes as the assembly: two matrices of nnz values and indices, in rows.
double ceiling_seconds(const SparseMatrix& pattern) {
  const Eigen::Index n = pattern.rows();
  const int* outer = pattern.outerIndexPtr();
  const auto t0 = std::chrono::steady_clock::now();
  for (int m = 0; m < 2; ++m) {
    std::unique_ptr<double[]> values(new double[pattern.nonZeros()]);
    std::unique_ptr<int[]> index(new int[pattern.nonZeros()]);
    std::unique_ptr<int[]> offsets(new int[n + 1]);
#pragma omp parallel for schedule(dynamic, 64)
    for (Eigen::Index r = 0; r < n; ++r) {
      offsets[r] = outer[r];
      for (int k = outer[r]; k < outer[r + 1]; ++k) values[k] = 1.0 + k, index[k] = static_cast<int>(k - outer[r]);
    }
    // Keep the writes observable.
    if (values[pattern.nonZeros() / 2] < 0 || index[0] < 0 || offsets[0] < 0) std::printf("!");
  }
  return seconds_since(t0);
}

void print_row(double h, const char* mode, int threads, Eigen::Index n, Eigen::Index nnz, double first, double best,
               double ceiling) {
  std::printf("| %g | %s | %d | %ld | %ld | %.4f | %.4f | %.0f | %.4f | %.0f%% |\n", h, mode, threads, static_cast<long>(n),
              static_cast<long>(nnz), first, best, static_cast<double>(nnz) / best / 1e6, ceiling, 100 * ceiling / best);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Heat Laplacian assembly throughput vs the memory-bandwidth ceiling (flower; unit sphere in 3D)."};
  std::vector<double> steps{0.002, 0.001}, surface_steps{0.05, 0.025};
  int repetitions = 5;
  app.add_option("--h", steps, "Grid steps")->capture_default_str();
  app.add_option("--surface-h", surface_steps, "Grid steps of the unit sphere (3D, defaults: II normals, c_t = 0.1)")
      ->capture_default_str();
  app.add_option("--repetitions", repetitions, "Best of this many runs")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  mallopt(M_MMAP_THRESHOLD, 1 << 30);  // large blocks from the heap, not fresh mmaps ...
  mallopt(M_TRIM_THRESHOLD, 1 << 30);  // ... and the heap is not returned to the system

  std::printf("| h | mode | threads | N | nnz | first run (s) | assembly (s) | Mnnz/s | ceiling (s) | ratio |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  Flower flower;
  for (double h : steps) {
    const DigitalSet set = digitize(flower, h);
    const ContourSet cs = track_contours(set);
    const Measures mu = measures(cs, ii_normals(set, cs));
    for (auto mode : {DistanceMode::Geodesic, DistanceMode::Euclidean})
      for (int threads : {1, 2}) {
        omp_set_num_threads(threads);
        HeatLaplacianOptions o;
        o.distance = mode;
        double best = 1e300, best_ceiling = 1e300, first = 0;
        Eigen::Index nnz = 0, n = 0;
        for (int r = 0; r < repetitions; ++r) {
          const auto t0 = std::chrono::steady_clock::now();
          const ContourOperator op = heat_laplacian(cs, mu, o);
          const double sec = seconds_since(t0);
          if (r == 0) first = sec;
          best = std::min(best, sec);
          nnz = op.L.nonZeros(), n = op.rows();
          best_ceiling = std::min(best_ceiling, ceiling_seconds(op.L));
        }
        print_row(h, mode == DistanceMode::Geodesic ? "geodesic" : "euclidean", threads, n, nnz, first, best, best_ceiling);
      }
  }
  // The same for digital surfaces (SPEC §7): the sphere, Euclidean distance in 3D.
  for (double h : surface_steps) {
    const surface::Sphere sphere;
    const surface::VoxelSet voxels = surface::digitize(sphere, h);
    const surface::SurfelSet surfels = surface::extract_surfels(voxels);
    const surface::SurfelMeasures mu = surface::measures(surfels, surface::ii_normals(voxels, surfels));
    for (int threads : {1, 2}) {
      omp_set_num_threads(threads);
      double best = 1e300, best_ceiling = 1e300, first = 0;
      Eigen::Index nnz = 0, n = 0;
      for (int r = 0; r < repetitions; ++r) {
        const auto t0 = std::chrono::steady_clock::now();
        const surface::SurfaceOperator op = surface::heat_laplacian(surfels, mu);
        const double sec = seconds_since(t0);
        if (r == 0) first = sec;
        best = std::min(best, sec);
        nnz = op.L.nonZeros(), n = op.rows();
        best_ceiling = std::min(best_ceiling, ceiling_seconds(op.L));
      }
      print_row(h, "sphere (3D)", threads, n, nnz, first, best, best_ceiling);
    }
  }
  return 0;
}
