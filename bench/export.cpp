// Writing the operator's files, in one process: Eigen's saveMarket (the baseline, what the
// library used before) against digilap's Matrix Market writer and .npz, on L and A of the flower
// at h = 0.001 with the former t = 0.1 h^(2/3) (1.03e7 nonzeros per matrix, issue 12's case).
// Each writer runs 3 times; the best time is reported with its ratio to the baseline.
#include "digilap/digilap.hpp"

#include <CLI/CLI.hpp>
#include <unsupported/Eigen/SparseExtra>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>

using namespace digilap;

namespace {
double best_of_3(const std::function<void()>& f) {
  double best = 1e300;
  for (int k = 0; k < 3; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  return best;
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"digilap-bench-export: Matrix Market and .npz writers against Eigen's saveMarket."};
  double h = 0.001;
  std::string dir = "/tmp/digilap-bench-export";
  app.add_option("--h", h, "Grid step")->capture_default_str();
  app.add_option("--dir", dir, "Scratch directory")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  std::filesystem::create_directories(dir);
  const DigitalSet set = digitize(Flower(), h);
  const ContourSet cs = track_contours(set);
  HeatLaplacianOptions o;
  o.c_t = 0.1;
  o.length_scale = 1.0;
  const ContourOperator op = heat_laplacian(cs, measures(cs, ii_normals(set, cs, {1.0, 1.0})), o);
  const double bytes_text = 2.0 * static_cast<double>(op.L.nonZeros());  // entries written
  const double baseline = best_of_3([&] {
    Eigen::saveMarket(op.L, dir + "/eigen_L.mtx");
    Eigen::saveMarket(op.A, dir + "/eigen_A.mtx");
  });
  const double market = best_of_3([&] {
    save_matrix_market(op.L, dir + "/L.mtx");
    save_matrix_market(op.A, dir + "/A.mtx");
  });
  const double npz = best_of_3([&] {
    save_npz(op.L, dir + "/L.npz");
    save_npz(op.A, dir + "/A.npz");
  });
  std::printf("flower, h = %g, N = %ld, %ld nonzeros per matrix, L and A written, best of 3\n\n", h,
              static_cast<long>(op.rows()), static_cast<long>(op.L.nonZeros()));
  std::printf("| writer | seconds | entries/s | speed-up over Eigen's saveMarket |\n|---|---|---|---|\n");
  for (auto [name, s] : {std::pair<const char*, double>{"Eigen::saveMarket (baseline)", baseline},
                         {"save_matrix_market", market}, {"save_npz", npz}})
    std::printf("| %s | %.3f | %.3g | %.1f |\n", name, s, bytes_text / s, baseline / s);
  std::filesystem::remove_all(dir);
  return 0;
}
