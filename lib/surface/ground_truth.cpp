#include "digilap/surface/ground_truth.hpp"

#include "digilap/core/error.hpp"

namespace digilap::surface {

SurfaceTestSamples sample_test_function(const Surface& surface, const std::string& function, const Eigen::MatrixX3d& positions) {
  const bool x2 = function == "x2";
  if (!x2 && function != "xy") throw Error("on surfaces the test functions are x2 and xy, got '" + function + "'");
  const Eigen::Index n = positions.rows();
  const Eigen::Vector3d c = surface.centre();
  SurfaceTestSamples s;
  s.values.resize(n);
  s.laplacians.resize(n);
  // Hess g is constant: x2 has tr = 2 and <n, Hess n> = 2 n_x^2; xy has tr = 0 and 2 n_x n_y.
#pragma omp parallel for schedule(static)
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector3d p = surface.closest_point(positions.row(i).transpose()), q = p - c, nrm = surface.normal(p);
    const double H = surface.mean_curvature(p);
    if (x2) {
      s.values[i] = q.x() * q.x();
      s.laplacians[i] = 2 - 2 * nrm.x() * nrm.x() - 2 * H * 2 * q.x() * nrm.x();
    } else {
      s.values[i] = q.x() * q.y();
      s.laplacians[i] = -2 * nrm.x() * nrm.y() - 2 * H * (q.y() * nrm.x() + q.x() * nrm.y());
    }
  }
  return s;
}

double relative_max_error(const Eigen::VectorXd& Lg, const SurfaceTestSamples& samples) {
  if (Lg.size() != samples.laplacians.size())
    throw Error("relative_max_error: L g has " + std::to_string(Lg.size()) + " values, the samples " +
                std::to_string(samples.laplacians.size()));
  return (Lg - samples.laplacians).cwiseAbs().maxCoeff() / samples.laplacians.cwiseAbs().maxCoeff();
}

}  // namespace digilap::surface
