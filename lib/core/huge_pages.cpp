#include "huge_pages.hpp"

#include <cstdint>
#include <cstdlib>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace digilap::detail {

void advise_huge_pages(void* data, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr std::uintptr_t kHuge = std::uintptr_t(2) << 20;
  // DIGILAP_NO_HUGE_PAGES=1 turns the advice off (benchmarks compare both).
  static const bool disabled = [] {
    const char* v = std::getenv("DIGILAP_NO_HUGE_PAGES");
    return v != nullptr && v[0] != '\0' && v[0] != '0';
  }();
  if (disabled || data == nullptr || bytes < 2 * kHuge) return;
  const auto begin = reinterpret_cast<std::uintptr_t>(data);
  const std::uintptr_t first = (begin + kHuge - 1) & ~(kHuge - 1), last = (begin + bytes) & ~(kHuge - 1);
  if (last > first) madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);  // advice only: errors ignored
#else
  (void)data;
  (void)bytes;
#endif
}

void resize_on_huge_pages(Eigen::MatrixXd& m, Eigen::Index rows, Eigen::Index cols) {
  if (m.size() == rows * cols) {  // Eigen keeps the buffer
    m.resize(rows, cols);
    return;
  }
  m = Eigen::MatrixXd();
  m.resize(rows, cols);
  advise_huge_pages(m.data(), sizeof(double) * static_cast<std::size_t>(m.size()));
}

}  // namespace digilap::detail
