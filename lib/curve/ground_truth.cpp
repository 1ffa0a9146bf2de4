#include "digilap/curve/ground_truth.hpp"
#include "digilap/core/constants.hpp"

#include "digilap/core/error.hpp"

#include <cmath>

namespace digilap {
inline namespace curve {

namespace {
}

Eigen::Vector2d curvature_vector(const Shape& shape, double theta) {
  const Eigen::Vector2d d1 = shape.derivative(theta), d2 = shape.second_derivative(theta);
  const Eigen::Vector2d T = d1.normalized();
  // d^2 gamma/ds^2 = (gamma'' - <gamma'', T> T) / |gamma'|^2: the normal part of gamma''.
  return (d2 - d2.dot(T) * T) / d1.squaredNorm();
}

TestFunction intrinsic_cosine(int m) {
  if (m < 0) throw Error("intrinsic_cosine: m must be >= 0, got " + std::to_string(m));
  TestFunction f;
  f.name = "cos" + std::to_string(m);
  f.value = [m](const Shape& s, double th) { return std::cos(2 * kPi * m * s.arclength(th) / s.length()); };
  f.laplacian = [m](const Shape& s, double th) {
    const double w = 2 * kPi * m / s.length();
    return -w * w * std::cos(w * s.arclength(th));
  };
  return f;
}

TestFunction ambient_function(std::string name, std::function<double(const Eigen::Vector2d&)> g,
                              std::function<Eigen::Vector2d(const Eigen::Vector2d&)> gradient,
                              std::function<Eigen::Matrix2d(const Eigen::Vector2d&)> hessian) {
  TestFunction f;
  f.name = std::move(name);
  f.value = [g](const Shape& s, double th) { return g(s.point(th)); };
  f.laplacian = [gradient, hessian](const Shape& s, double th) {
    const Eigen::Vector2d p = s.point(th), T = s.tangent(th);
    return T.dot(hessian(p) * T) + gradient(p).dot(curvature_vector(s, th));
  };
  return f;
}

TestFunction ambient_x2() {
  return ambient_function(
      "x2", [](const Eigen::Vector2d& p) { return p.x() * p.x(); },
      [](const Eigen::Vector2d& p) { return Eigen::Vector2d(2 * p.x(), 0.0); },
      [](const Eigen::Vector2d&) { return (Eigen::Matrix2d() << 2, 0, 0, 0).finished(); });
}

TestFunction ambient_xy() {
  return ambient_function(
      "xy", [](const Eigen::Vector2d& p) { return p.x() * p.y(); },
      [](const Eigen::Vector2d& p) { return Eigen::Vector2d(p.y(), p.x()); },
      [](const Eigen::Vector2d&) { return (Eigen::Matrix2d() << 0, 1, 1, 0).finished(); });
}

TestFunction make_test_function(const std::string& name) {
  if (name == "x2") return ambient_x2();
  if (name == "xy") return ambient_xy();
  if (name.size() == 4 && name.compare(0, 3, "cos") == 0 && name[3] >= '0' && name[3] <= '9')
    return intrinsic_cosine(name[3] - '0');
  throw Error("unknown test function '" + name + "' (known: cos1 .. cos9, x2, xy)");
}

Eigen::VectorXd sample_parameters(const Shape& shape, const Eigen::MatrixX2d& positions, Sampling sampling) {
  const Eigen::Index n = positions.rows();
  Eigen::VectorXd theta(n);
#pragma omp parallel for schedule(dynamic, 256)
  for (Eigen::Index r = 0; r < n; ++r) {
    const Eigen::Vector2d p = positions.row(r).transpose();
    if (sampling == Sampling::ClosestPoint) {
      theta[r] = shape.closest_parameter(p);
    } else {
      theta[r] = shape.radial_parameter(p);
    }
  }
  return theta;
}

Eigen::VectorXd sample_values(const Shape& shape, const TestFunction& f, const Eigen::VectorXd& theta) {
  Eigen::VectorXd v(theta.size());
#pragma omp parallel for schedule(static)
  for (Eigen::Index r = 0; r < theta.size(); ++r) v[r] = f.value(shape, theta[r]);
  return v;
}

Eigen::VectorXd sample_laplacian(const Shape& shape, const TestFunction& f, const Eigen::VectorXd& theta) {
  Eigen::VectorXd v(theta.size());
#pragma omp parallel for schedule(static)
  for (Eigen::Index r = 0; r < theta.size(); ++r) v[r] = f.laplacian(shape, theta[r]);
  return v;
}

}  // namespace curve
}  // namespace digilap
