// Internal: the hot loop of the assembly, w = scale * exp(-d2 / (4t)) over a row.
#pragma once

#include <Eigen/Core>

namespace digilap {

/// In place: values[k] <- scale * exp(-values[k] * inv_4t) for k < count.
void gaussian_weights(double* values, Eigen::Index count, double inv_4t, double scale);

}  // namespace digilap
