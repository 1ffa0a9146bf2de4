#include "digilap/surface/ground_truth.hpp"

#include "digilap/core/constants.hpp"
#include "digilap/core/error.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <vector>

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

Eigen::VectorXd sphere_spectrum(double radius, int count) {
  if (count < 1) throw Error("sphere_spectrum: count must be at least 1, got " + std::to_string(count));
  require_positive("sphere_spectrum: radius", radius);
  Eigen::VectorXd out(count);
  for (int k = 0, l = 0; k < count; ++l)
    for (int m = 0; m <= 2 * l && k < count; ++m) out[k++] = l * (l + 1.0) / (radius * radius);
  return out;
}

namespace {
// The eigenvalues of the periodic problem in phi for the mode n, on `points` nodes: the
// symmetric form M^(-1/2) K M^(-1/2) of K u = lambda M u, K the flux stencil (w at the half
// nodes) plus r^2 n^2 / w, M = r^2 w, both times the node spacing. Dense: a few hundred nodes.
Eigen::VectorXd torus_mode_values(double R, double r, int n, int points) {
  const double d = 2 * kPi / points;
  auto w = [&](double phi) { return R + r * std::cos(phi); };
  Eigen::MatrixXd k = Eigen::MatrixXd::Zero(points, points);
  Eigen::VectorXd root_mass(points);
  for (int j = 0; j < points; ++j) {
    const int next = (j + 1) % points;
    const double flux = w(d * (j + 0.5)) / d;
    k(j, j) += flux, k(next, next) += flux, k(j, next) -= flux, k(next, j) -= flux;
    k(j, j) += r * r * n * n * d / w(d * j);
    root_mass[j] = std::sqrt(r * r * w(d * j) * d);
  }
  const Eigen::MatrixXd symmetric = root_mass.cwiseInverse().asDiagonal() * k * root_mass.cwiseInverse().asDiagonal();
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(symmetric, Eigen::EigenvaluesOnly).eigenvalues();  // ascending
}
}  // namespace

Eigen::VectorXd torus_spectrum(double R, double r, int count) {
  if (count < 1 || count > 200) throw Error("torus_spectrum: count must be in [1, 200], got " + std::to_string(count));
  require_positive("torus_spectrum: r", r);
  if (!(R > r) || !std::isfinite(R)) throw Error("torus_spectrum: needs R > r > 0 (a ring torus)");
  constexpr int kCoarse = 256, kFine = 512;
  std::vector<double> values;
  for (int n = 0;; ++n) {
    const Eigen::VectorXd coarse = torus_mode_values(R, r, n, kCoarse), fine = torus_mode_values(R, r, n, kFine);
    std::vector<double> mode;
    for (int m = 0; m < count; ++m) mode.push_back((4 * fine[m] - coarse[m]) / 3);  // Richardson: O(d^2) out
    if (n > 0 && static_cast<int>(values.size()) >= count) {
      std::vector<double> sorted = values;
      std::nth_element(sorted.begin(), sorted.begin() + (count - 1), sorted.end());
      if (mode[0] > sorted[static_cast<std::size_t>(count - 1)]) break;  // every further n starts higher still
    }
    for (double v : mode)
      for (int copy = 0; copy < (n == 0 ? 1 : 2); ++copy) values.push_back(v);
  }
  std::sort(values.begin(), values.end());
  Eigen::VectorXd out(count);
  for (int k = 0; k < count; ++k) out[k] = values[static_cast<std::size_t>(k)];
  out[0] = 0;  // the constants, exactly
  return out;
}

double relative_max_error(const Eigen::VectorXd& Lg, const SurfaceTestSamples& samples) {
  if (Lg.size() != samples.laplacians.size())
    throw Error("relative_max_error: L g has " + std::to_string(Lg.size()) + " values, the samples " +
                std::to_string(samples.laplacians.size()));
  return (Lg - samples.laplacians).cwiseAbs().maxCoeff() / samples.laplacians.cwiseAbs().maxCoeff();
}

}  // namespace digilap::surface
