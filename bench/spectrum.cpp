// Time of the smallest eigenpairs through Spectra (shift-and-invert, sparse LDL^T) on the
// flower, next to Eigen's dense generalized solver on the sizes it can handle, in one process.
#include "digilap/curve/spectrum.hpp"

#include <CLI/CLI.hpp>
#include <Eigen/Dense>
#include <omp.h>

#include <chrono>
#include <cmath>
#include <cstdio>

using namespace digilap;

namespace {
double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Spectrum benchmark: 20 smallest eigenpairs (Spectra) vs dense (Eigen), flower."};
  std::vector<double> sparse_steps{0.01, 0.005, 0.002, 0.001}, dense_steps{0.04, 0.02, 0.01};
  int count = 20;
  app.add_option("--h", sparse_steps, "Grid steps for Spectra")->capture_default_str();
  app.add_option("--dense-h", dense_steps, "Grid steps for the dense solver (N^3!)")->capture_default_str();
  app.add_option("--count", count, "Eigenpairs")->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  Flower flower;
  std::printf("threads: %d\n\n| solver | h | N | nnz(A) | seconds | lambda_%d |\n|---|---|---|---|---|---|\n",
              omp_get_max_threads(), count - 1);
  auto build = [&](double h) {
    const DigitalSet set = digitize(flower, h);
    const ContourSet cs = track_contours(set);
    return heat_laplacian(cs, measures(cs, ii_normals(set, cs)));
  };
  for (double h : sparse_steps) {
    const ContourOperator op = build(h);
    SpectrumOptions o;
    o.count = count;
    const auto t0 = std::chrono::steady_clock::now();
    const Spectrum s = smallest_eigenpairs(op, o);
    const double sec = seconds_since(t0);
    std::printf("| Spectra shift-invert (LDLT) | %g | %ld | %ld | %.3f | %.6f |\n", h, static_cast<long>(op.rows()),
                static_cast<long>(op.A.nonZeros()), sec, s.eigenvalues[count - 1]);
  }
  for (double h : dense_steps) {
    const ContourOperator op = build(h);
    const auto t0 = std::chrono::steady_clock::now();
    const Eigen::MatrixXd K = -Eigen::MatrixXd(op.A);
    Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> eig(K, Eigen::MatrixXd(op.mass.asDiagonal()));
    const double sec = seconds_since(t0);
    std::printf("| Eigen dense GeneralizedSelfAdjointEigenSolver | %g | %ld | %ld | %.3f | %.6f |\n", h,
                static_cast<long>(op.rows()), static_cast<long>(op.A.nonZeros()), sec, eig.eigenvalues()[count - 1]);
  }
  return 0;
}
