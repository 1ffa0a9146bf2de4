// digilap internal — a dense voxel grid (any reader: .npy, NIfTI) turned into a VoxelSet of runs
// by a foreground predicate, one row along x at a time.
#pragma once

#include "digilap/surface/digitization.hpp"
#include "digilap/surface/volume.hpp"
#include "digilap/core/error.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <cstdio>
#include <utility>
#include <vector>

namespace digilap::surface::detail {

/// The foreground rule of VolumeOptions: the label when one is given (within float rounding:
/// an int16 label times a float scl_slope, 30 x 0.1 = 3.0000000447, is label 3), else the threshold.
inline bool is_foreground(const VolumeOptions& o, double value) {
  if (o.label < 0) return value >= o.threshold;
  const auto label = static_cast<double>(o.label);
  return std::abs(value - label) <= 1e-6 * std::max(1.0, label);
}
/// Throws digilap::Error naming a NaN voxel: NaN is neither a label nor above a threshold, and
/// reading it as background would silently cut a hole in the object.
[[noreturn]] inline void refuse_nan_voxel(const std::string& path, std::int64_t i, std::int64_t j, std::int64_t k) {
  char where[120];
  std::snprintf(where, sizeof where, "voxel (%lld, %lld, %lld) is NaN", static_cast<long long>(i), static_cast<long long>(j),
                static_cast<long long>(k));
  throw Error("cannot read volume '" + path + "': " + where + " (replace NaN first, e.g. np.nan_to_num)");
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

/// Voxel (i, j, k), 0 <= i < nx, 0 <= j < ny, k_first <= k < k_first + nz, is in the set when
/// inside(i, j, k); the set has step h (k_first > 0: a slab of planes, volume.hpp's
/// read_volume_slab). Two passes (count the runs of each row, then write them): the storage is
/// the final one, at most 16 bytes per voxel of the grid whatever its shape (no list per row:
/// issue 25).
template <class Inside>
VoxelSet voxel_set_from_grid(double h, std::int64_t nx, std::int64_t ny, std::int64_t nz, Inside&& inside, std::int64_t k_first = 0) {
  auto scan = [&](std::int64_t r, auto&& emit) {
    const std::int64_t j = r % ny, k = k_first + r / ny;
    for (std::int64_t i = 0; i < nx;) {
      if (!inside(i, j, k)) { ++i; continue; }
      std::int64_t e = i;
      while (e < nx && inside(e, j, k)) ++e;
      emit(Run{static_cast<std::int32_t>(i), static_cast<std::int32_t>(e)});
      i = e;
    }
  };
  const std::int64_t rows = ny * nz;
  std::vector<std::int64_t> row_offset(static_cast<std::size_t>(rows) + 1, 0);
  for (std::int64_t r = 0; r < rows; ++r) {
    row_offset[static_cast<std::size_t>(r) + 1] = row_offset[static_cast<std::size_t>(r)];
    scan(r, [&](const Run&) { ++row_offset[static_cast<std::size_t>(r) + 1]; });
  }
  std::vector<Run> runs(static_cast<std::size_t>(row_offset.back()));
  std::size_t at = 0;
  for (std::int64_t r = 0; r < rows; ++r) scan(r, [&](const Run& run) { runs[at++] = run; });
  return VoxelSet::from_compressed_rows(h, 0, static_cast<std::int32_t>(k_first), static_cast<std::int32_t>(ny),
                                        static_cast<std::int32_t>(nz), std::move(row_offset), std::move(runs));
}

/// The integer label a value stands for: the value itself, or the nearest integer when the value
/// is within float rounding of it (an int16 label times a float scl_slope: 30 x 0.1 =
/// 3.0000000447). Throws digilap::Error naming the voxel for a value that is no label.
inline std::int64_t label_of(const std::string& path, double value, std::int64_t i, std::int64_t j, std::int64_t k) {
  const double nearest = std::round(value);
  if (std::isfinite(value) && std::abs(value - nearest) <= 1e-6 * std::max(1.0, std::abs(value)) && std::abs(nearest) < 9e15)
    return static_cast<std::int64_t>(nearest);
  char where[160];
  std::snprintf(where, sizeof where, "the value %.9g at voxel (%lld, %lld, %lld) is not an integer label", value,
                static_cast<long long>(i), static_cast<long long>(j), static_cast<long long>(k));
  throw Error("cannot read the labels of '" + path + "': " + where + " (a probability or intensity volume: give a threshold instead)");
}

/// One voxel set per distinct non-zero label of the grid, ascending, in one pass over it.
template <class Value>
std::vector<LabelVoxels> label_sets_from_grid(const std::string& path, double h, std::int64_t nx, std::int64_t ny, std::int64_t nz,
                                              const Value& value) {
  std::map<std::int64_t, std::vector<std::vector<Run>>> rows;  // label -> its rows of runs
  const auto row_count = static_cast<std::size_t>(ny * nz);
  for (std::int64_t k = 0; k < nz; ++k)
    for (std::int64_t j = 0; j < ny; ++j)
      for (std::int64_t i = 0; i < nx;) {
        const std::int64_t label = label_of(path, value(i, j, k), i, j, k);
        std::int64_t e = i + 1;
        while (e < nx && value(e, j, k) == value(i, j, k)) ++e;
        if (label != 0) {
          auto& own = rows[label];
          if (own.empty()) own.resize(row_count);
          own[static_cast<std::size_t>(k * ny + j)].push_back({static_cast<std::int32_t>(i), static_cast<std::int32_t>(e)});
        }
        i = e;
      }
  std::vector<LabelVoxels> out;
  for (auto& [label, own] : rows)
    out.push_back({label, VoxelSet::from_rows(h, 0, 0, static_cast<std::int32_t>(ny), static_cast<std::int32_t>(nz), std::move(own))});
  return out;
}

/// The per-format halves of read_volume_info and read_volume_slab (volume.cpp, nifti_volume.cpp).
VolumeInfo npy_volume_info(const std::string& path, const VolumeOptions& o);
VolumeInfo nifti_volume_info(const std::string& path, const VolumeOptions& o);
VoxelSet read_npy_slab(const std::string& path, std::int64_t k_begin, std::int64_t k_end, const VolumeOptions& o);
VoxelSet read_nifti_slab(const std::string& path, std::int64_t k_begin, std::int64_t k_end, const VolumeOptions& o);

}  // namespace digilap::surface::detail
