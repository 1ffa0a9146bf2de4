// digilap — exact test functions on the reference surfaces, sampled at closest points (SPEC §7),
// the 3D sibling of curve/ground_truth.hpp: what the convergence app, the benchmarks and the
// tests compare the surface operator with.
//
// An ambient function g, taken about the surface's centre (q = p - centre), restricted to the
// surface at the closest point p of each position: its exact Laplace-Beltrami is
//
//   Delta_S g = tr(Hess g) - <n, Hess g n> - 2 H <grad g, n>,
//
// with n the outward normal and H the mean curvature at p (> 0 on a sphere).
#pragma once

#include "digilap/surface/shapes.hpp"

#include <Eigen/Core>

#include <string>

namespace digilap::surface {

/// g and Delta_S g at the closest points of the positions (rows) on the surface.
struct SurfaceTestSamples {
  Eigen::VectorXd values;
  Eigen::VectorXd laplacians;
};

/// The test function `function` ("x2": g = q_x^2, "xy": g = q_x q_y, q relative to the
/// surface's centre) sampled at the closest points of `positions` (in parallel, the same for
/// any thread count). Throws digilap::Error for another name, listing the known ones.
SurfaceTestSamples sample_test_function(const Surface& surface, const std::string& function, const Eigen::MatrixX3d& positions);

/// The `count` smallest Laplace-Beltrami eigenvalues (0 first, with multiplicity) of the sphere
/// of radius r: l(l+1) / r^2, 2l + 1 times. Throws digilap::Error for count < 1 or r not > 0.
Eigen::VectorXd sphere_spectrum(double radius, int count);

/// The same for the torus of radii R > r > 0, which has no closed form, by separation of
/// variables: with w = R + r cos(phi) and f = e^(i n theta) u(phi),
///   -(w u')' + r^2 n^2 u / w = lambda r^2 w u   over periodic u(phi)
/// (each n > 0 twice), solved by second-order finite differences on 256 and 512 nodes and
/// Richardson-extrapolated: relative error below 1e-6 for the first 50 eigenvalues. Throws
/// digilap::Error for count outside [1, 200] or radii not R > r > 0.
Eigen::VectorXd torus_spectrum(double R, double r, int count);

/// max |L g - Delta_S g| / max |Delta_S g|: the relative max error of an operator's L g
/// against the samples (the convergence tables' figure).
double relative_max_error(const Eigen::VectorXd& Lg, const SurfaceTestSamples& samples);

}  // namespace digilap::surface
