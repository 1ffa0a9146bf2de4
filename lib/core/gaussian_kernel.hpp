// Internal: the hot loop of the assembly, w = scale * exp(-d2 / (4t)) over a row.
#pragma once

#include <Eigen/Core>

namespace digilap {

/// In place: values[k] <- scale * exp(-values[k] * inv_4t) for k < count.
void gaussian_weights(double* values, Eigen::Index count, double inv_4t, double scale);

/// The same, with AVX-512's exp where the CPU has it (the matrix-free surface products).
void gaussian_weights_wide(double* values, Eigen::Index count, double inv_4t, double scale);

}  // namespace digilap
