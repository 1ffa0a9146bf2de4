// digilap — exact test functions on reference shapes, sampled at closest points (SPEC §5).
//
// A function on the continuous curve is sampled at the orthogonal projection of each element
// on the curve. Sampling at the raw position adds an O(h) jitter that the 1/t of the operator
// amplifies to O(h^(1/3)) (SPEC §5): the choice is exposed so that users can see it.
#pragma once

#include "digilap/curve/shapes.hpp"

#include <Eigen/Core>

#include <functional>
#include <string>

namespace digilap {
inline namespace curve {

/// A function on the curve with its exact Laplace-Beltrami (d^2/ds^2), both given as functions
/// of the curve parameter theta.
struct TestFunction {
  std::string name;
  std::function<double(const Shape&, double theta)> value;
  std::function<double(const Shape&, double theta)> laplacian;
};

/// g(s) = cos(2 pi m s / P), s the arclength of the point, P the exact length:
/// Delta g = -(2 pi m / P)^2 g.
TestFunction intrinsic_cosine(int m = 1);

/// Restriction of an ambient function g(x, y) to the curve: Delta g = T^t (Hess g) T + <grad g, gamma_ss>.
TestFunction ambient_function(std::string name, std::function<double(const Eigen::Vector2d&)> g,
                              std::function<Eigen::Vector2d(const Eigen::Vector2d&)> gradient,
                              std::function<Eigen::Matrix2d(const Eigen::Vector2d&)> hessian);
TestFunction ambient_x2();  ///< g = x^2
TestFunction ambient_xy();  ///< g = x y

/// Test functions by name: "cos1".."cos9" (intrinsic cosine with that m), "x2", "xy".
/// Throws digilap::Error for an unknown name, listing the known ones.
TestFunction make_test_function(const std::string& name);

/// How positions are turned into curve parameters for sampling.
enum class Sampling {
  ClosestPoint,  ///< orthogonal projection on the curve (SPEC §5: the right one)
  Radial,        ///< the curve point in the direction of the position from the shape's centre
};

/// Curve parameters of the given positions (one per row), in parallel.
Eigen::VectorXd sample_parameters(const Shape& shape, const Eigen::MatrixX2d& positions,
                                  Sampling sampling = Sampling::ClosestPoint);

/// Values and exact Laplacians of f at the given parameters.
Eigen::VectorXd sample_values(const Shape& shape, const TestFunction& f, const Eigen::VectorXd& theta);
Eigen::VectorXd sample_laplacian(const Shape& shape, const TestFunction& f, const Eigen::VectorXd& theta);

/// Curvature vector d^2 gamma / ds^2 at theta.
Eigen::Vector2d curvature_vector(const Shape& shape, double theta);

}  // namespace curve
}  // namespace digilap
