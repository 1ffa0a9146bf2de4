// One heat_laplacian call on the flower (h = 0.001 by default), as a baseline for the Python
// module's overhead (bench/python_overhead.py runs this and the same call from Python, each in a
// fresh process). Prints the best of 5 seconds and the growth of the peak resident set (KiB)
// caused by the first call.
#include "digilap/digilap.hpp"

#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>

using namespace digilap;

namespace {
long peak_kib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss;
}
}  // namespace

int main(int argc, char** argv) {
  const double h = argc > 1 ? std::atof(argv[1]) : 0.001;
  const DigitalSet set = digitize(Flower(), h);
  const ContourSet contours = track_contours(set);
  const Measures mu = measures(contours, ii_normals(set, contours));
  const long before = peak_kib();
  double best = 1e300;
  long growth = 0;
  for (int k = 0; k < 5; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    const ContourOperator op = heat_laplacian(contours, mu);
    best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    if (k == 0) growth = peak_kib() - before;
    if (op.rows() == 0) return 1;
  }
  std::printf("%.6f %ld\n", best, growth);
  return 0;
}
