// digilap internal — a dense voxel grid (any reader: .npy, NIfTI) turned into a VoxelSet of runs
// by a foreground predicate, one row along x at a time.
#pragma once

#include "digilap/surface/digitization.hpp"
#include "digilap/surface/volume.hpp"

#include <string>

#include <cstdint>
#include <cstdio>
#include <utility>
#include <vector>

namespace digilap::surface::detail {

/// The foreground rule of VolumeOptions: the label when one is given, else the threshold.
inline bool is_foreground(const VolumeOptions& o, double value) {
  return o.label >= 0 ? value == static_cast<double>(o.label) : value >= o.threshold;
}
/// A count from a header as text: whole below 2^63, else in exponent form (a header may declare
/// sizes no integer type holds; converting those would be undefined behaviour).
inline std::string count_text(double count) {
  if (count < 9.2e18) return std::to_string(static_cast<long long>(count));
  char text[32];
  std::snprintf(text, sizeof text, "%.4g", count);
  return text;
}
/// Why a volume gave no voxel.
inline std::string no_foreground_reason(const VolumeOptions& o) {
  return o.label >= 0 ? "no voxel has the label " + std::to_string(o.label) : "no voxel reaches the threshold";
}

/// Voxel (i, j, k), 0 <= i < nx, ..., is in the set when inside(i, j, k); the set has step h.
template <class Inside>
VoxelSet voxel_set_from_grid(double h, std::int64_t nx, std::int64_t ny, std::int64_t nz, Inside&& inside) {
  std::vector<std::vector<Run>> rows(static_cast<std::size_t>(ny * nz));
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < ny; ++j) {
      std::vector<Run>& row = rows[static_cast<std::size_t>(k * ny + j)];
      for (std::int64_t i = 0; i < nx;) {
        if (!inside(i, j, k)) { ++i; continue; }
        std::int64_t e = i;
        while (e < nx && inside(e, j, k)) ++e;
        row.push_back({static_cast<std::int32_t>(i), static_cast<std::int32_t>(e)});
        i = e;
      }
    }
  return VoxelSet::from_rows(h, 0, 0, static_cast<std::int32_t>(ny), static_cast<std::int32_t>(nz), std::move(rows));
}

}  // namespace digilap::surface::detail
