// digilap — files: Matrix Market for the matrices, CSV for the elements.
#pragma once

#include "digilap/heat_laplacian.hpp"

#include <string>

namespace digilap {

/// Writes a sparse matrix in Matrix Market coordinate format (readable by SciPy's mmread,
/// MATLAB's mmread, Julia's MatrixMarket). Throws digilap::Error if the file cannot be written.
void save_matrix_market(const SparseMatrix& matrix, const std::string& path);

/// Reads a Matrix Market coordinate file, real or integer, general or symmetric (a symmetric
/// file holds the lower triangle, mirrored here; duplicate entries are summed, as SciPy does).
/// Throws digilap::Error naming the file and the line for anything else: an empty file, another
/// format, field or symmetry, an index out of range, fewer or more entries than declared.
SparseMatrix load_matrix_market(const std::string& path);

/// Writes one line per row of the operator: row, contour, index, x, y, mu, s
/// (element position, measure and arclength coordinate), with a header line.
void save_elements_csv(const ContourOperator& op, const std::string& path);

/// Writes L.mtx, A.mtx, M.mtx and elements.csv into `directory` (created if missing), with
/// an optional file-name prefix. Returns the paths written, in that order.
std::vector<std::string> save_operator(const ContourOperator& op, const std::string& directory,
                                       const std::string& prefix = "");

}  // namespace digilap
