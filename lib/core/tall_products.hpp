// Internal: the dense products of a block eigen-solver on tall, skinny blocks (N rows, tens of
// columns), on one thread: G = X^T Y and Z = X C (or Z -= X C).
//
// Why not Eigen's: the library is built for baseline x86-64, so Eigen's products run on SSE2
// (2 doubles a register); these kernels are built for AVX-512, AVX2 and the baseline and pick
// the CPU's best at run time (LOBPCG's dense algebra was 15% of a surface spectrum's time with
// Eigen's). Each result's sum runs in a fixed order (rows in lanes of 8, then the lanes added
// in a fixed order), so a given CPU always gives the same bits.
#pragma once

#include <Eigen/Core>

namespace digilap::detail {

using ConstBlockRef = Eigen::Ref<const Eigen::MatrixXd, 0, Eigen::OuterStride<>>;
using BlockRef = Eigen::Ref<Eigen::MatrixXd, 0, Eigen::OuterStride<>>;

/// out = x^T y (out: x.cols() x y.cols(), column-major, resized by the caller). x and y have
/// the same number of rows.
void tall_gram(const ConstBlockRef& x, const ConstBlockRef& y, BlockRef out);

/// out = x c, or out -= x c with `subtract` (out: x.rows() x c.cols(); not aliased with x).
void tall_product(const ConstBlockRef& x, const Eigen::MatrixXd& c, BlockRef out, bool subtract);

}  // namespace digilap::detail
