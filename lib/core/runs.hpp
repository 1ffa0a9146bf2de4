// Internal: runs of consecutive pixels or voxels along a row, shared by 2D and 3D sets.
#pragma once

#include "digilap/core/runs.hpp"

#include <algorithm>
#include <cstdint>
#include <vector>

namespace digilap::detail {

/// Sorts the runs of a row and merges the overlapping or touching ones; empty runs go.
inline void normalize_runs(std::vector<Run>& runs) {
  runs.erase(std::remove_if(runs.begin(), runs.end(), [](const Run& r) { return r.end <= r.begin; }), runs.end());
  std::sort(runs.begin(), runs.end(), [](const Run& a, const Run& b) { return a.begin < b.begin; });
  std::size_t out = 0;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    if (out > 0 && runs[k].begin <= runs[out - 1].end) runs[out - 1].end = std::max(runs[out - 1].end, runs[k].end);
    else runs[out++] = runs[k];
  }
  runs.resize(out);
}

/// Whether i lies in one of the sorted, disjoint runs [b, e).
inline bool in_runs(const Run* b, const Run* e, std::int32_t i) {
  const Run* it = std::upper_bound(b, e, i, [](std::int32_t v, const Run& r) { return v < r.begin; });
  return it != b && i < (it - 1)->end;
}

/// The number of pixels or voxels the runs hold.
inline std::int64_t run_total(const std::vector<Run>& runs) {
  std::int64_t n = 0;
  for (const Run& r : runs) n += std::int64_t(r.end) - r.begin;  // a run may span 2^31 + 1 indices
  return n;
}

}  // namespace digilap::detail
