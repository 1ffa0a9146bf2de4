// Internal: transparent huge pages for the big buffers. A fresh buffer is faulted in page by
// page on first write; with 4 KiB pages that ran at 0.3 GB/s on the project's machine (3 GiB
// of L and A at h = 1e-4: seconds of page faults before any arithmetic), with 2 MiB pages at
// 1.1 GB/s. Where the kernel's THP mode is "madvise" (Debian's default), a buffer gets huge
// pages only when asked, before it is touched: that is what this does.
#pragma once

#include <Eigen/Core>

#include <cstddef>

namespace digilap::detail {

/// Asks the kernel to back the 2 MiB-aligned part of [data, data + bytes) with huge pages.
/// Call it on memory not yet written. A no-op for buffers under 4 MiB, and where madvise or
/// MADV_HUGEPAGE is unavailable, and when the environment sets DIGILAP_NO_HUGE_PAGES=1; never
/// fails.
void advise_huge_pages(void* data, std::size_t bytes);

/// m made rows x cols, its values undefined. When that needs a new buffer (another number of
/// values), the old one is freed first and the new one advised before anything writes it: the
/// blocks that products and solvers reallocate as their column count changes.
void resize_on_huge_pages(Eigen::MatrixXd& m, Eigen::Index rows, Eigen::Index cols);

}  // namespace digilap::detail
