// The matrix-free surface products alone (issue 23): one surface at grid step h, its operator
// built once, then Y = A X for blocks of 1, 8 and 30 columns (30 is the LOBPCG block of 20
// eigenpairs). Prints one table row per block: the first product (cold: its memory touched for
// the first time) and the best of 5 after it (warm), seconds, and pairs a second.
//   digilap-bench-surface-products [H [SURFACE [KERNEL [CT]]]]  (defaults 0.025 torus intrinsic 0.1; CT: the heat
//   time's c_t, docs/accuracy.md "The heat time for eigenvalues")
#include "digilap/surface/matrix_free.hpp"
#include "digilap/surface/measures.hpp"
#include "digilap/surface/normals.hpp"
#include "digilap/surface/shapes.hpp"
#include "digilap/surface/digitization.hpp"
#include "digilap/surface/surfels.hpp"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>

using namespace digilap;
using namespace digilap::surface;

int main(int argc, char** argv) {
  const double h = argc > 1 ? std::atof(argv[1]) : 0.025;
  const auto shape = make_surface(argc > 2 ? argv[2] : "torus:R=1,r=0.4");
  HeatLaplacianOptions options;
  if (argc > 3 && std::strcmp(argv[3], "chord") == 0) options.surface_kernel = SurfaceKernel::Chord;
  if (argc > 4) options.c_t = std::atof(argv[4]);
  const VoxelSet voxels = digitize(*shape, h);
  const SurfelSet surfels = extract_surfels(voxels);
  const SurfelMeasures mu = measures(surfels, ii_normals(voxels, surfels));
  const MatrixFreeSurfaceOperator op(surfels, mu, options);
  const Eigen::Index n = op.rows();
  std::printf("| surface | h | N | columns | first product (s) | best of 5 (s) | column products / s |\n|---|---|---|---|---|---|---|\n");
  std::mt19937 random(7);
  std::uniform_real_distribution<double> uniform(-1, 1);
  const char* only = std::getenv("DIGILAP_BENCH_COLUMNS");  // one block width (profiling)
  for (Eigen::Index b : {1, 8, 30}) {
    if (only && std::atol(only) != b) continue;
    Eigen::MatrixXd x(n, b), y;
    for (Eigen::Index k = 0; k < x.size(); ++k) x.data()[k] = uniform(random);
    auto seconds = [&] {
      const auto t0 = std::chrono::steady_clock::now();
      op.apply_stiffness(x, y);
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    };
    const double cold = seconds();
    double warm = 1e300;
    const int repeats = std::getenv("DIGILAP_BENCH_REPEATS") ? std::atoi(std::getenv("DIGILAP_BENCH_REPEATS")) : 5;
    for (int k = 0; k < repeats; ++k) warm = std::min(warm, seconds());
    std::printf("| %s | %g | %ld | %ld | %.4f | %.4f | %.1f |\n", shape->name().c_str(), h, static_cast<long>(n), static_cast<long>(b), cold,
                warm, static_cast<double>(b) / warm);
    std::fflush(stdout);
  }
  return 0;
}
