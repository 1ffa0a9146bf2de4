// digilap — matrix files, for operators of any dimension (core): Matrix Market and SciPy's .npz.
#pragma once

#include "digilap/core/operator.hpp"

#include <string>
#include <vector>

namespace digilap {

/// Writes a sparse matrix in Matrix Market coordinate format (readable by SciPy's mmread,
/// MATLAB's mmread, Julia's MatrixMarket), every value in the shortest text that reads back
/// to the same double; rows formatted in parallel. Throws digilap::Error if the file cannot
/// be written.
void save_matrix_market(const SparseMatrix& matrix, const std::string& path);

/// Writes a sparse matrix as scipy.sparse.save_npz does for a csr_matrix (an uncompressed
/// .npz of data, indices, indptr, format and shape): scipy.sparse.load_npz(path) reads it,
/// bit for bit. Members or offsets of 4 GiB and more are written in ZIP64 form, which NumPy and
/// SciPy read.
void save_npz(const SparseMatrix& matrix, const std::string& path);

enum class FileFormat { MatrixMarket, Npz };

/// Reads a Matrix Market coordinate file, real or integer, general or symmetric (a symmetric
/// file holds the lower triangle, mirrored here; duplicate entries are summed, as SciPy does).
/// Throws digilap::Error naming the file and the line for anything else: an empty file, another
/// format, field or symmetry, an index out of range, fewer or more entries than declared.
SparseMatrix load_matrix_market(const std::string& path);

/// Writes an operator's matrices, of any dimension: L.mtx, A.mtx and M.mtx (or L.npz, A.npz,
/// M.npz) into `directory` (created if missing), with an optional file-name prefix; A is left
/// out when the operator was assembled without it. Returns the paths written, in that order.
/// (Surfaces: surface::save_ply writes the surfels with their measures beside them.)
std::vector<std::string> save_operator(const HeatOperator& op, const std::string& directory,
                                       const std::string& prefix = "", FileFormat format = FileFormat::MatrixMarket);

}  // namespace digilap
