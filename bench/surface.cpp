// A reference surface (centre off the lattice) from shape to operator, stage by stage, with the
// x^2 error against the exact Laplace-Beltrami operator (SPEC §7) and the peak memory. One
// configuration per process:
//   digilap-bench-surface H C_T [SURFACE [L [K_R]]]
// SURFACE: sphere (default), ellipsoid, torus, with parameters; L: the length scale (default 1,
// the reference computation's t = C_T h^(2/3); 0 measures it); K_R: the II constant (default 1).
#include "digilap/surface/ground_truth.hpp"
#include "digilap/surface/heat_laplacian.hpp"

#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>

using namespace digilap;
using namespace digilap::surface;

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: digilap-bench-surface H C_T [SURFACE [L [K_R]]]   (prints one table row)\n");
    return 2;
  }
  const double h = std::atof(argv[1]), c_t = std::atof(argv[2]);
  const auto shape = make_surface(argc > 3 ? argv[3] : "sphere");
  const double length_scale = argc > 4 ? std::atof(argv[4]) : 1.0, k_R = argc > 5 ? std::atof(argv[5]) : 1.0;
  Surface& sphere = *shape;
  const Eigen::Vector3d centre(0.0123, -0.0371, 0.0217);
  sphere.set_pose(centre, Eigen::Matrix3d::Identity());
  auto seconds = [](auto t0) { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  const auto t0 = std::chrono::steady_clock::now();
  const VoxelSet voxels = digitize(sphere, h);
  const SurfelSet surfels = extract_surfels(voxels);
  const double t_digitize = seconds(t0);
  const auto t1 = std::chrono::steady_clock::now();
  const SurfelMeasures mu = measures(surfels, ii_normals(voxels, surfels, {k_R, length_scale}));
  const double t_normals = seconds(t1);
  const auto t2 = std::chrono::steady_clock::now();
  HeatLaplacianOptions o;
  o.c_t = c_t;
  o.length_scale = length_scale;
  o.memory_limit_bytes = 20e9;
  const SurfaceOperator op = heat_laplacian(surfels, mu, o);
  const double t_operator = seconds(t2), t_total = seconds(t0);
  const SurfaceTestSamples x2 = sample_test_function(sphere, "x2", op.positions);
  const double error = relative_max_error(op.L * x2.values, x2);
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  // II normals: O((R/h)^2) per surfel (the ball's voxel rows meet the runs), so this is flat in h.
  const double ball_rows = std::pow(mu.normal_radius / h, 2);
  std::printf("| %s | %g | %g | %.3g | %ld | %.3g | %.3f | %.3f | %.1f | %.3f | %.3f | %.3g | %.2f%% | %.2f |\n", sphere.name().c_str(), h,
              c_t, mu.length_scale, static_cast<long>(op.rows()),
              static_cast<double>(op.L.nonZeros()), t_digitize, t_normals,
              1e9 * t_normals / (static_cast<double>(op.rows()) * ball_rows), t_operator, t_total,
              static_cast<double>(op.L.nonZeros()) / t_operator, 100 * error, usage.ru_maxrss / 1048576.0);
  return 0;
}
