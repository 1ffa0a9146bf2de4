// digilap — binary digital sets and the Gauss digitization of shapes (SPEC §1).
//
// A DigitalSet is a set of pixels (i, j) of the grid hZ^2, pixel (i, j) being the point (i h, j h).
// It is stored as sorted runs of consecutive pixels per row, so its memory grows with the number
// of boundary crossings (the perimeter / h), not with the area (perimeter / h)^2: the flower at
// h = 1e-4 (2.5e9 grid points in its box) takes about 1 MB.
#pragma once

#include "digilap/core/runs.hpp"
#include "digilap/curve/shapes.hpp"

#include <cstdint>
#include <vector>

namespace digilap {
inline namespace curve {

class DigitalSet {
public:
  DigitalSet() = default;
  /// Empty set with grid step h (h > 0, finite).
  explicit DigitalSet(double h);

  double h() const { return h_; }
  bool empty() const { return runs_.empty(); }
  /// First and one-past-last row index holding pixels (row_end() == row_begin() when empty).
  std::int32_t row_begin() const { return row_begin_; }
  std::int32_t row_end() const { return row_begin_ + static_cast<std::int32_t>(row_offset_.size()) - 1; }
  /// The runs of row j, sorted, disjoint and not touching (an empty range outside the rows).
  /// Inline: the II normals call these O(R/h) times per linel.
  const Run* row_runs_begin(std::int32_t j) const {
    if (j < row_begin() || j >= row_end()) return runs_.data();
    return runs_.data() + row_offset_[static_cast<std::size_t>(j - row_begin_)];
  }
  const Run* row_runs_end(std::int32_t j) const {
    if (j < row_begin() || j >= row_end()) return runs_.data();
    return runs_.data() + row_offset_[static_cast<std::size_t>(j - row_begin_) + 1];
  }
  std::size_t run_count() const { return runs_.size(); }

  bool contains(std::int32_t i, std::int32_t j) const;
  std::int64_t pixel_count() const;
  /// Bytes held by the run storage (what "memory proportional to the boundary" means).
  std::size_t memory_bytes() const;

  /// Builders throw digilap::Error for a pixel index outside [-kMaxPixelIndex, kMaxPixelIndex],
  /// and for a set whose rows span more than 2^24 rows while holding 64 times fewer runs (the
  /// set keeps one offset per row between its first and last: such a sparse set would take
  /// memory by its span, not by its boundary).
  /// Build from rows given as possibly unsorted, overlapping runs (normalized here).
  static DigitalSet from_rows(double h, std::int32_t row_begin, std::vector<std::vector<Run>> rows);
  /// Build from a row-major bitmap of width x height (nonzero = in the set); bitmap row r is
  /// grid row j = r + row_offset and column c is i = c + col_offset.
  static DigitalSet from_bitmap(double h, int width, int height, const std::vector<std::uint8_t>& bitmap,
                                std::int32_t col_offset = 0, std::int32_t row_offset = 0);
  /// Build from a list of pixels (duplicates allowed).
  static DigitalSet from_pixels(double h, const std::vector<Eigen::Vector2i>& pixels);

private:
  double h_ = 1.0;
  std::int32_t row_begin_ = 0;
  std::vector<std::int64_t> row_offset_{0};  // runs of row row_begin_ + r: [offset[r], offset[r+1])
  std::vector<Run> runs_;
};

/// Gauss digitization D_h(M) = M ∩ (hZ)^2 of a shape: the pixels whose centre is inside.
/// Computed row by row from the crossings of the curve with the lines y = j h (safeguarded
/// Newton on monotone pieces of the curve), each run end checked with the exact inside test,
/// so the result agrees with Shape::inside pixel by pixel. Cost O(#rows + #samples), memory
/// O(#runs). Throws digilap::Error for h <= 0, non-finite h, or a grid too fine for 32-bit
/// pixel indices.
DigitalSet digitize(const Shape& shape, double h);

}  // namespace curve
}  // namespace digilap
