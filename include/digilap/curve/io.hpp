// digilap — files of contour operators: the matrices (core/io.hpp) and the element table, as CSV
// or .npz.
#pragma once

#include "digilap/core/io.hpp"
#include "digilap/curve/heat_laplacian.hpp"

#include <string>
#include <vector>

namespace digilap {
inline namespace curve {

/// The element table as an .npz: contour, index (int64), positions (N x 2), mu, s (float64).
void save_elements_npz(const ContourOperator& op, const std::string& path);

/// Writes one line per row of the operator: row, contour, index, x, y, mu, s
/// (element position, measure and arclength coordinate), with a header line.
void save_elements_csv(const ContourOperator& op, const std::string& path);

/// Contours: the matrices as above, then elements.csv (or L.npz, A.npz, M.npz and elements.npz) into
/// `directory`. Returns the paths written, in that order.
std::vector<std::string> save_operator(const ContourOperator& op, const std::string& directory,
                                       const std::string& prefix = "", FileFormat format = FileFormat::MatrixMarket);

}  // namespace curve
}  // namespace digilap
