// The whole pipeline stage by stage on the flower, for several h and 1 or 2 threads: time, N,
// nnz and peak memory. Each configuration runs in its own child process (fork), so that its
// peak resident memory (getrusage) is its own.
#include "digilap/digilap.hpp"

#include <CLI/CLI.hpp>
#include <omp.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

using namespace digilap;

namespace {
// The parameters of the run (--length-scale 1 --ct 0.03 --kR 1: the former defaults).
struct Parameters {
  double length_scale = 0, c_t = HeatLaplacianOptions{}.c_t, k_R = IINormalOptions{}.k_R;
} parameters;

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }
constexpr int kProducts = 20;  // products timed per operator
double best(const std::vector<double>& times) { return *std::min_element(times.begin(), times.end()); }
double median(std::vector<double> times) {
  std::nth_element(times.begin(), times.begin() + times.size() / 2, times.end());
  return times[times.size() / 2];
}
double peak_gb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss / 1024.0 / 1024.0;  // ru_maxrss is in KiB on Linux
}

void run(double h, int threads, double eigen_min_h, double free_eigen_min_h, double memory_limit) {
  omp_set_num_threads(threads);
  Flower flower;
  std::string row;
  char cell[64];
  auto add = [&](const char* fmt, double v) {
    std::snprintf(cell, sizeof cell, fmt, v);
    row += " | ";
    row += cell;
  };
  double t0 = now();
  const DigitalSet set = digitize(flower, h);
  const double t_digitize = now() - t0;
  t0 = now();
  const ContourSet contours = track_contours(set);
  const double t_contours = now() - t0;
  t0 = now();
  const LinelNormals normals = ii_normals(set, contours, {parameters.k_R, parameters.length_scale});
  const double t_normals = now() - t0;
  t0 = now();
  const Measures mu = measures(contours, normals);
  const double t_measures = now() - t0;
  const double peak_front = peak_gb();
  HeatLaplacianOptions o;
  o.c_t = parameters.c_t;
  o.stiffness = h >= eigen_min_h;  // A only where the factorized solvers run
  o.memory_limit_bytes = memory_limit;
  const Eigen::VectorXd ones_like = Eigen::VectorXd::Ones(static_cast<Eigen::Index>(contours.linel_count()));
  t0 = now();
  const MatrixFreeLaplacian mf(contours, mu, o);
  const double t_free_setup = now() - t0;
  std::fprintf(stderr, "h %g, %d threads: matrix-free loops built for %s\n", h, threads,
               mf.wide_kernels() ? "AVX2 + FMA" : "plain x86-64 (DIGILAP_PLAIN_KERNELS, or a CPU without AVX2)");
  const Eigen::VectorXd x = ones_like + 0.1 * mf.positions().col(0);
  // Products: kProducts of each, their best and their median (one product is at the mercy of
  // the machine's noise; on the project's virtual machine the matrix-free one, compute-bound,
  // varies by up to 1.5x from one product to the next, the memory-bound explicit one less).
  Eigen::VectorXd z;
  std::vector<double> free_times;
  for (int r = 0; r < kProducts; ++r) {
    t0 = now();
    z = mf * x;
    free_times.push_back(now() - t0);
  }
  const double t_free = best(free_times), t_free_median = median(free_times);
  t0 = now();
  int cg_iterations = 0;
  heat_step_cg(mf, x, mf.t(), 1e-10, &cg_iterations);
  const double t_heat = now() - t0;
  // 10 eigenpairs through the matrix-free operator (default options: LOBPCG), and their worst
  // relative error against the exact (2 pi m / P)^2, m = 1..4 (eigenvalues 1..8, in pairs).
  double t_free_eigen = -1, free_eigen_error = -1;
  int free_eigen_products = 0;
  if (h >= free_eigen_min_h) {
    t0 = now();
    const Spectrum sf = smallest_eigenpairs(mf, {10});
    t_free_eigen = now() - t0;
    free_eigen_products = sf.operations;
    const double P = flower.length();
    free_eigen_error = 0;
    for (int k = 1; k <= 8; ++k) {
      const double exact = std::pow(2 * 3.14159265358979323846 * ((k + 1) / 2) / P, 2);
      free_eigen_error = std::max(free_eigen_error, std::abs(sf.eigenvalues[k] - exact) / exact);
    }
  }
  std::string explicit_cells;
  double t_assemble = -1, t_matvec = -1, t_matvec_median = -1, agreement = -1, t_eigen = -1;
  long nnz = -1;
  try {
    t0 = now();
    const ContourOperator op = heat_laplacian(contours, mu, o);
    t_assemble = now() - t0;
    nnz = static_cast<long>(op.L.nonZeros());
    Eigen::VectorXd y;
    std::vector<double> times;
    for (int r = 0; r < kProducts; ++r) {
      t0 = now();
      y = op.L * x;
      times.push_back(now() - t0);
    }
    t_matvec = best(times);
    t_matvec_median = median(times);
    agreement = (y - z).cwiseAbs().maxCoeff() / (op.L.diagonal().cwiseAbs().maxCoeff() * x.cwiseAbs().maxCoeff());
    if (h >= eigen_min_h) {
      t0 = now();
      smallest_eigenpairs(op, {10});
      t_eigen = now() - t0;
    }
  } catch (const Error& e) {
    explicit_cells = e.what();
  }
  std::snprintf(cell, sizeof cell, "| %g | %d | %ld | %ld", h, threads, static_cast<long>(mf.rows()), nnz);
  row = cell;
  for (double v : {t_digitize, t_contours, t_normals, t_measures}) add("%.3f", v);
  add("%.2f", peak_front);
  if (t_assemble >= 0) {
    add("%.3f", t_assemble);
    add("%.4f", t_matvec);
  } else {
    row += " | refused: " + explicit_cells.substr(0, explicit_cells.find(';')) + " | -";
  }
  add("%.3f", t_free_setup);
  add("%.4f", t_free);
  if (t_matvec >= 0) {
    add("%.0f", t_matvec / t_free);
    add("%.0f", t_matvec_median / t_free_median);
    add("%.0e", agreement);
  } else {
    row += " | - | - | -";
  }
  std::snprintf(cell, sizeof cell, " | %.3f (%d it.)", t_heat, cg_iterations);
  row += cell;
  if (t_eigen >= 0) add("%.2f", t_eigen);
  else row += " | -";
  if (t_free_eigen >= 0) {
    std::snprintf(cell, sizeof cell, " | %.1f (%d products) | %.1e", t_free_eigen, free_eigen_products, free_eigen_error);
    row += cell;
  } else {
    row += " | - | -";
  }
  add("%.2f", peak_gb());
  std::printf("%s |\n", row.c_str());
  std::fflush(stdout);
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"digilap-bench: the pipeline stage by stage on the flower (time in s, peak memory in GiB)."};
  std::vector<double> steps{1e-2, 3e-3, 1e-3, 3e-4, 1e-4};
  std::vector<int> threads{1, 2};
  double eigen_min_h = 1e-3, free_eigen_min_h = 3e-5, memory_limit = 20e9;
  app.add_option("--h", steps, "Grid steps")->capture_default_str();
  app.add_option("--threads", threads, "Thread counts")->capture_default_str();
  app.add_option("--eigen-min-h", eigen_min_h, "Smallest h for the factorized 10 eigenpairs")->capture_default_str();
  app.add_option("--free-eigen-min-h", free_eigen_min_h, "Smallest h for the matrix-free 10 eigenpairs")->capture_default_str();
  app.add_option("--memory-limit", memory_limit, "Bytes the operator may take")->capture_default_str();
  app.add_option("--length-scale", parameters.length_scale, "l (0: measured; 1 with --ct 0.03 --kR 1: the former defaults)")
      ->capture_default_str();
  app.add_option("--ct", parameters.c_t, "Heat time constant")->capture_default_str();
  app.add_option("--kR", parameters.k_R, "II radius constant")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  std::printf("| h | threads | N | nnz(L) | digitize | contours | normals | measures | peak GiB after measures | assemble | "
              "mat-vec | matrix-free setup | matrix-free mat-vec | speed-up | speed-up, medians | agreement | "
              "heat step (CG, matrix-free) | 10 eigenpairs | 10 eigenpairs, matrix-free | worst error m <= 4 | peak GiB |\n"
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  std::fflush(stdout);
  for (double h : steps)
    for (int t : threads) {
      const pid_t pid = fork();
      if (pid == 0) {
        try {
          run(h, t, eigen_min_h, free_eigen_min_h, memory_limit);
        } catch (const std::exception& e) {
          std::printf("| %g | %d | error: %s |\n", h, t, e.what());
        }
        std::fflush(stdout);
        _exit(0);
      }
      int status = 0;
      waitpid(pid, &status, 0);
    }
  return 0;
}
