// Internal: runs of consecutive pixels or voxels along a row, shared by 2D and 3D sets.
#pragma once

#include "digilap/digitization.hpp"

#include <algorithm>
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

}  // namespace digilap::detail
