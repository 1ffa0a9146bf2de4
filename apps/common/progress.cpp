#include "progress.hpp"

#include "digilap/core/error.hpp"

#include <cstdio>
#include <iostream>
#include <new>

namespace digilap::app {

void Progress::start(const std::string& stage) {
  stage_ = stage;
  t0_ = std::chrono::steady_clock::now();
  if (!quiet_) std::fprintf(stderr, "  %-12s ...", stage.c_str()), std::fflush(stderr);
}

double Progress::finish() {
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
  if (!quiet_) std::fprintf(stderr, " %8.3f s\n", s);
  return s;
}

void Progress::bar(const std::string& label, double fraction) {
  if (quiet_) return;
  const int width = 30, filled = static_cast<int>(fraction * width + 0.5);
  std::fprintf(stderr, "\r%s [%s%s] %3d%%", label.c_str(), std::string(filled, '#').c_str(),
               std::string(width - filled, '.').c_str(), static_cast<int>(100 * fraction + 0.5));
  std::fflush(stderr);
}

void Progress::end_bar() {
  if (!quiet_) std::fprintf(stderr, "\n");
}

int guarded_main(const std::function<int()>& body) {
  try {
    return body();
  } catch (const Error& e) {
    std::cerr << "error: " << e.what() << "\n";
  } catch (const std::bad_alloc&) {
    // Which parameter helps depends on the stage (a smaller t shrinks the explicit operator but
    // not the matrix-free one): the estimates before each big allocation say; this is the rest.
    std::cerr << "error: out of memory: the machine could not provide what this run asked for; "
                 "use a coarser h or fewer eigenpairs, or set --memory-limit to have sizes checked first\n";
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
  }
  return 1;
}

}  // namespace digilap::app
