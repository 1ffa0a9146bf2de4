// Internal: the hot loop of the assembly, w = scale * exp(-d2 / (4t)) over a row.
#pragma once

#include <Eigen/Core>

namespace digilap {

/// In place: values[k] <- scale * exp(-values[k] * inv_4t) for k < count; exactly 0 where
/// values[k] is +infinity (the surface products' pairs left out), or the argument below -708.
void gaussian_weights(double* values, Eigen::Index count, double inv_4t, double scale);

/// Values a buffer of gaussian_weights_wide must have room for: count rounded up to 64.
inline Eigen::Index gaussian_weights_room(Eigen::Index count) { return (count + 63) / 64 * 64; }

/// The same, with AVX-512's exp where the CPU has it (the matrix-free surface products), in
/// place without the copies through an aligned chunk that gaussian_weights makes (4% of a
/// surface spectrum's run): values must be 64-byte aligned, with room for
/// gaussian_weights_room(count) of them; the values past count are overwritten.
void gaussian_weights_wide(double* values, Eigen::Index count, double inv_4t, double scale);

}  // namespace digilap
