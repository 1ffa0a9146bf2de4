// digilap — sets of voxels and the Gauss digitization of surfaces (SPEC §7), stored as runs
// along x per (y, z) row: memory grows with the surface, not the volume. The 3D sibling of
// curve/digitization.hpp.
#pragma once

#include "digilap/core/runs.hpp"
#include "digilap/surface/shapes.hpp"

#include <cstdint>
#include <vector>

namespace digilap::surface {

/// Voxels (i, j, k) of the grid hZ^3, voxel (i, j, k) being the point (i h, j h, k h). Indices
/// lie in [-kMaxPixelIndex, kMaxPixelIndex].
class VoxelSet {
public:
  VoxelSet() = default;
  explicit VoxelSet(double h);

  double h() const { return h_; }
  bool empty() const { return runs_.empty(); }
  /// The rows (j, k) that may hold voxels: j in [j_begin, j_end), k in [k_begin, k_end).
  std::int32_t j_begin() const { return j0_; }
  std::int32_t j_end() const { return j0_ + nj_; }
  std::int32_t k_begin() const { return k0_; }
  std::int32_t k_end() const { return k0_ + nk_; }
  /// The runs of row (j, k), sorted and disjoint (an empty range outside the rows): the names of
  /// DigitalSet::row_runs_begin(j), whose row_begin() is a row index.
  const Run* row_runs_begin(std::int32_t j, std::int32_t k) const { return runs_.data() + offset(j, k, 0); }
  const Run* row_runs_end(std::int32_t j, std::int32_t k) const { return runs_.data() + offset(j, k, 1); }
  [[deprecated("renamed row_runs_begin(j, k), as in 2D (row_begin() is a row index there)")]]
  const Run* row_begin(std::int32_t j, std::int32_t k) const { return row_runs_begin(j, k); }
  [[deprecated("renamed row_runs_end(j, k), as in 2D")]]
  const Run* row_end(std::int32_t j, std::int32_t k) const { return row_runs_end(j, k); }
  bool contains(std::int32_t i, std::int32_t j, std::int32_t k) const;
  std::int64_t voxel_count() const;
  std::size_t memory_bytes() const;

  /// From rows of runs: rows[(k - k0) * nj + (j - j0)] holds row (j, k) (unsorted, overlapping
  /// runs are normalized). Throws digilap::Error for indices out of range.
  static VoxelSet from_rows(double h, std::int32_t j0, std::int32_t k0, std::int32_t nj, std::int32_t nk,
                            std::vector<std::vector<Run>> rows);
  /// From rows already in compressed form, moved in without a copy: row r = (k - k0) nj + (j - j0)
  /// holds runs[row_offset[r], row_offset[r + 1]), sorted, disjoint and non-empty (checked).
  /// Memory: 8 bytes per row and per run, so at most 16 bytes per voxel of the grid whatever its
  /// shape (the volume readers build this directly). Throws digilap::Error for malformed rows.
  static VoxelSet from_compressed_rows(double h, std::int32_t j0, std::int32_t k0, std::int32_t nj, std::int32_t nk,
                                       std::vector<std::int64_t> row_offset, std::vector<Run> runs);
  /// From a dense mask read in place: voxel (i, j, k), 0 <= i < nx, 0 <= j < ny, 0 <= k < nz, is
  /// in the set when the byte at data + i stride_i + j stride_j + k stride_k is not 0 (strides
  /// in bytes, of any order or sign: C or Fortran arrays, views, NumPy's strides as they are).
  /// Throws digilap::Error for h not > 0 and finite, or sizes out of range.
  static VoxelSet from_mask(double h, const std::uint8_t* data, std::int64_t nx, std::int64_t ny, std::int64_t nz,
                            std::ptrdiff_t stride_i, std::ptrdiff_t stride_j, std::ptrdiff_t stride_k);
  /// From a list of voxels (duplicates allowed).
  static VoxelSet from_voxels(double h, const std::vector<Eigen::Vector3i>& voxels);

private:
  std::size_t offset(std::int32_t j, std::int32_t k, int end) const {
    if (j < j0_ || j >= j0_ + nj_ || k < k0_ || k >= k0_ + nk_) return 0;
    return static_cast<std::size_t>(row_offset_[static_cast<std::size_t>(k - k0_) * nj_ + (j - j0_) + end]);
  }
  double h_ = 1.0;
  std::int32_t j0_ = 0, k0_ = 0, nj_ = 0, nk_ = 0;
  std::vector<std::int64_t> row_offset_{0};
  std::vector<Run> runs_;
};

/// Gauss digitization: the voxels whose centre is strictly inside the surface. Row by row from
/// the surface's crossings with the lines along x, each run end checked with the exact inside
/// test. Parallel over rows; memory O(rows + runs). Throws digilap::Error for h not > 0 and
/// finite, or a grid too fine for the index range or for the memory of its rows.
VoxelSet digitize(const Surface& surface, double h);

}  // namespace digilap::surface
