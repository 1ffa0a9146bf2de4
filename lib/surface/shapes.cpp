#include "digilap/surface/shapes.hpp"
#include "digilap/core/constants.hpp"

#include "digilap/core/error.hpp"
#include "core/shape_parameters.hpp"

#include <unsupported/Eigen/Polynomials>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <sstream>

namespace digilap::surface {

namespace {

void require_finite(const Eigen::Vector3d& p, const char* what) {
  if (!p.allFinite()) throw Error(std::string(what) + ": the point is not finite");
}

// Roots of a x^2 + b x + c (a > 0), sorted; none when the discriminant is negative.
std::vector<double> quadratic_roots(double a, double b, double c) {
  const double disc = b * b - 4 * a * c;
  if (disc < 0) return {};
  const double s = std::sqrt(disc);
  // The stable pair: q = -(b + sign(b) s) / 2, roots q / a and c / q.
  const double q = -0.5 * (b + (b >= 0 ? s : -s));
  std::vector<double> r;
  if (q != 0) r = {q / a, c / q};
  else r = {0.0, 0.0};
  std::sort(r.begin(), r.end());
  return r;
}
}  // namespace

// --- Surface ----------------------------------------------------------------------------------

void Surface::set_pose(const Eigen::Vector3d& centre, const Eigen::Matrix3d& rotation) {
  if (!centre.allFinite() || !rotation.allFinite() || (rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).norm() > 1e-9 ||
      rotation.determinant() < 0)
    throw Error(name() + ": the pose needs a finite centre and a rotation matrix (orthonormal, determinant 1)");
  centre_ = centre;
  rotation_ = rotation;
}

bool Surface::inside(const Eigen::Vector3d& p) const { return local_inside(rotation_.transpose() * (p - centre_)); }

Eigen::Vector3d Surface::closest_point(const Eigen::Vector3d& p) const {
  require_finite(p, "closest_point");
  return rotation_ * local_closest_point(rotation_.transpose() * (p - centre_)) + centre_;
}

Eigen::Vector3d Surface::normal(const Eigen::Vector3d& p) const {
  return rotation_ * local_normal(rotation_.transpose() * (p - centre_));
}

double Surface::mean_curvature(const Eigen::Vector3d& p) const {
  return local_mean_curvature(rotation_.transpose() * (p - centre_));
}

Eigen::AlignedBox3d Surface::bounding_box() const {
  const Eigen::Vector3d half = rotation_.cwiseAbs() * local_half_extent();
  return {centre_ - half, centre_ + half};
}

std::vector<std::pair<double, double>> Surface::x_intervals(double y, double z) const {
  const Eigen::Vector3d q0 = rotation_.transpose() * (Eigen::Vector3d(0, y, z) - centre_);
  const Eigen::Vector3d d = rotation_.transpose() * Eigen::Vector3d::UnitX();
  const std::vector<double> s = local_crossings(q0, d);
  std::vector<std::pair<double, double>> intervals;
  for (std::size_t k = 0; k + 1 < s.size(); ++k) {
    if (!(s[k + 1] > s[k])) continue;
    if (local_inside(q0 + 0.5 * (s[k] + s[k + 1]) * d)) {
      if (!intervals.empty() && intervals.back().second == s[k]) intervals.back().second = s[k + 1];
      else intervals.emplace_back(s[k], s[k + 1]);
    }
  }
  return intervals;
}

// --- Sphere -----------------------------------------------------------------------------------

Sphere::Sphere(double r) : r_(r) { require_positive("sphere: radius", r); }
double Sphere::area() const { return 4 * kPi * r_ * r_; }
bool Sphere::local_inside(const Eigen::Vector3d& q) const { return q.squaredNorm() < r_ * r_; }
Eigen::Vector3d Sphere::local_closest_point(const Eigen::Vector3d& q) const {
  const double n = q.norm();
  return n > 0 ? Eigen::Vector3d(r_ * q / n) : Eigen::Vector3d(r_, 0, 0);  // the centre: any point
}
Eigen::Vector3d Sphere::local_normal(const Eigen::Vector3d& q) const { return q.normalized(); }
double Sphere::local_mean_curvature(const Eigen::Vector3d&) const { return 1 / r_; }
Eigen::Vector3d Sphere::local_half_extent() const { return Eigen::Vector3d::Constant(r_); }
std::vector<double> Sphere::local_crossings(const Eigen::Vector3d& q0, const Eigen::Vector3d& d) const {
  return quadratic_roots(d.squaredNorm(), 2 * q0.dot(d), q0.squaredNorm() - r_ * r_);
}

// --- Ellipsoid --------------------------------------------------------------------------------

Ellipsoid::Ellipsoid(double a, double b, double c) : axes_(a, b, c) {
  require_positive("ellipsoid: a", a);
  require_positive("ellipsoid: b", b);
  require_positive("ellipsoid: c", c);
  // Area by Gauss-Legendre in (theta, phi) of |d_theta x d_phi| for x = (a sin th cos ph,
  // b sin th sin ph, c cos th): 64 panels of 8 nodes in each, analytic integrand, far below 1e-12.
  static const double node[8] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290, -0.1834346424956498,
                                 0.1834346424956498,  0.5255324099163290,  0.7966664774136267,  0.9602898564975363};
  static const double weight[8] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873, 0.3626837833783620,
                                   0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763};
  constexpr int kPanels = 64;
  double sum = 0;
  for (int pt = 0; pt < kPanels; ++pt)
    for (int qt = 0; qt < 8; ++qt) {
      const double th = (pt + 0.5 + 0.5 * node[qt]) * kPi / kPanels, wt = weight[qt] * 0.5 * kPi / kPanels;
      const double st = std::sin(th), ct = std::cos(th);
      for (int pp = 0; pp < kPanels; ++pp)
        for (int qp = 0; qp < 8; ++qp) {
          const double ph = (pp + 0.5 + 0.5 * node[qp]) * 2 * kPi / kPanels, wp = weight[qp] * 0.5 * 2 * kPi / kPanels;
          const double sp = std::sin(ph), cp = std::cos(ph);
          const Eigen::Vector3d dth(a * ct * cp, b * ct * sp, -c * st), dph(-a * st * sp, b * st * cp, 0);
          sum += wt * wp * dth.cross(dph).norm();
        }
    }
  area_ = sum;
}
bool Ellipsoid::local_inside(const Eigen::Vector3d& q) const { return q.cwiseQuotient(axes_).squaredNorm() < 1; }
Eigen::Vector3d Ellipsoid::local_closest_point(const Eigen::Vector3d& q) const {
  // x_i = a_i^2 y_i / (t + a_i^2) with sum (x_i / a_i)^2 = 1 (Lagrange), y = |q| in the first
  // octant: F(t) = sum (a_i y_i / (t + a_i^2))^2 - 1 decreases from +inf at t = -min a_i^2 to -1,
  // one root, found by bisection to full precision. A point on a symmetry plane inside the
  // ellipsoid (y_i = 0 on the shortest axis) is nudged off it by 1e-300: its projection is
  // then one of the two symmetric ones.
  const Eigen::Vector3d a2 = axes_.cwiseProduct(axes_), y = q.cwiseAbs().cwiseMax(1e-300);
  double lo = -a2.minCoeff(), hi = axes_.maxCoeff() * y.norm() + 1;
  for (int it = 0; it < 200; ++it) {
    const double t = 0.5 * (lo + hi);
    if (t <= lo || t >= hi) break;
    double f = -1;
    for (int i = 0; i < 3; ++i) f += std::pow(axes_[i] * y[i] / (t + a2[i]), 2);
    (f > 0 ? lo : hi) = t;
  }
  const double t = 0.5 * (lo + hi);
  Eigen::Vector3d x;
  for (int i = 0; i < 3; ++i) x[i] = std::copysign(a2[i] * y[i] / (t + a2[i]), q[i]);
  return x;
}
Eigen::Vector3d Ellipsoid::local_normal(const Eigen::Vector3d& q) const {
  return q.cwiseQuotient(axes_.cwiseProduct(axes_)).normalized();
}
double Ellipsoid::local_mean_curvature(const Eigen::Vector3d& q) const {
  // H = (a^2 + b^2 + c^2 - |x|^2) / (2 a^2 b^2 c^2 (x^2/a^4 + y^2/b^4 + z^2/c^4)^(3/2)).
  const Eigen::Vector3d a2 = axes_.cwiseProduct(axes_);
  const double g = q.cwiseQuotient(a2).squaredNorm();
  return (a2.sum() - q.squaredNorm()) / (2 * a2.prod() * std::pow(g, 1.5));
}
std::vector<double> Ellipsoid::local_crossings(const Eigen::Vector3d& q0, const Eigen::Vector3d& d) const {
  const Eigen::Vector3d qa = q0.cwiseQuotient(axes_), da = d.cwiseQuotient(axes_);
  return quadratic_roots(da.squaredNorm(), 2 * qa.dot(da), qa.squaredNorm() - 1);
}

// --- Torus ------------------------------------------------------------------------------------

Torus::Torus(double R, double r) : R_(R), r_(r) {
  require_positive("torus: r", r);
  if (!(R > r && std::isfinite(R))) throw Error("torus: need R > r > 0 (a ring around a hole), got R = " + std::to_string(R));
}
double Torus::area() const { return 4 * kPi * kPi * R_ * r_; }
bool Torus::local_inside(const Eigen::Vector3d& q) const {
  const double rho = std::hypot(q.x(), q.y()) - R_;
  return rho * rho + q.z() * q.z() < r_ * r_;
}
Eigen::Vector3d Torus::local_closest_point(const Eigen::Vector3d& q) const {
  const double rho = std::hypot(q.x(), q.y());
  // The nearest point of the core circle, then the tube around it (on the axis: any direction).
  const Eigen::Vector3d ring = rho > 0 ? Eigen::Vector3d(R_ * q.x() / rho, R_ * q.y() / rho, 0) : Eigen::Vector3d(R_, 0, 0);
  const Eigen::Vector3d away = q - ring;
  const double n = away.norm();
  return ring + (n > 0 ? Eigen::Vector3d(r_ * away / n) : Eigen::Vector3d(r_ * ring / R_));
}
Eigen::Vector3d Torus::local_normal(const Eigen::Vector3d& q) const {
  const double rho = std::hypot(q.x(), q.y());
  return (q - Eigen::Vector3d(R_ * q.x() / rho, R_ * q.y() / rho, 0)).normalized();
}
double Torus::local_mean_curvature(const Eigen::Vector3d& q) const {
  // Principal curvatures 1 / r (around the tube) and cos(v) / (R + r cos v) (around the axis),
  // cos v = (rho - R) / r.
  const double cos_v = (std::hypot(q.x(), q.y()) - R_) / r_;
  return 0.5 * (1 / r_ + cos_v / (R_ + r_ * cos_v));
}
std::vector<double> Torus::local_crossings(const Eigen::Vector3d& q0, const Eigen::Vector3d& d) const {
  // f(s) = (|q|^2 + R^2 - r^2)^2 - 4 R^2 (qx^2 + qy^2) along q = q0 + s d, |d| = 1: a quartic.
  const double A = q0.dot(d), B = q0.squaredNorm() + R_ * R_ - r_ * r_;
  const double e = d.x() * d.x() + d.y() * d.y(), g = q0.x() * d.x() + q0.y() * d.y(), w = q0.x() * q0.x() + q0.y() * q0.y();
  const double R2 = R_ * R_;
  Eigen::Matrix<double, 5, 1> c;  // ascending powers
  c << B * B - 4 * R2 * w, 4 * A * B - 8 * R2 * g, 4 * A * A + 2 * B - 4 * R2 * e, 4 * A, 1;
  Eigen::PolynomialSolver<double, 4> solver(c);
  auto f = [&](double s) { return Eigen::poly_eval(c, s); };
  auto df = [&](double s) { return ((4 * s + 3 * c[3]) * s + 2 * c[2]) * s + c[1]; };
  std::vector<double> roots;
  for (Eigen::Index k = 0; k < solver.roots().size(); ++k) {
    const std::complex<double> z = solver.roots()[k];
    if (std::abs(z.imag()) > 1e-6 * (1 + std::abs(z.real()))) continue;
    double s = z.real();
    for (int it = 0; it < 4; ++it) {  // polish: the companion matrix leaves ~1e-12
      const double slope = df(s);
      if (slope == 0) break;
      s -= f(s) / slope;
    }
    roots.push_back(s);
  }
  std::sort(roots.begin(), roots.end());
  return roots;
}

// --- By name ----------------------------------------------------------------------------------

namespace {
// The table of make_surface(), surface_names() and surface_syntax(): names, keys, defaults.
struct SurfaceKind {
  const char* name;
  std::vector<std::pair<const char*, double>> keys;  // SPEC §7's reference parameters
};
const std::vector<SurfaceKind>& surface_kinds() {
  static const std::vector<SurfaceKind> kinds = {
      {"sphere", {{"r", 1.0}}},
      {"ellipsoid", {{"a", 1.2}, {"b", 1.0}, {"c", 0.8}}},
      {"torus", {{"R", 1.0}, {"r", 0.4}}},
  };
  return kinds;
}
}  // namespace

std::vector<std::string> surface_names() {
  std::vector<std::string> names;
  for (const SurfaceKind& kind : surface_kinds()) names.emplace_back(kind.name);
  return names;
}

std::string surface_syntax() {
  std::string text;
  for (const SurfaceKind& kind : surface_kinds()) {
    text += detail::syntax_line(kind.name, kind.keys);
  }
  return text;
}

std::unique_ptr<Surface> make_surface(const std::string& spec) {
  const std::size_t colon = spec.find(':');
  const std::string name = spec.substr(0, colon);
  std::vector<std::pair<std::string, double>> value;
  for (const SurfaceKind& kind : surface_kinds())
    if (name == kind.name) value.assign(kind.keys.begin(), kind.keys.end());
  if (value.empty()) {
    std::string known;
    for (const std::string& n : surface_names()) known += (known.empty() ? "" : ", ") + n;
    throw Error("unknown surface '" + name + "' (known surfaces: " + known + ")");
  }
  if (colon != std::string::npos) detail::read_shape_parameters(name, spec.substr(colon + 1), value);
  auto get = [&](const char* key) { return detail::parameter(value, key); };
  if (name == "sphere") return std::make_unique<Sphere>(get("r"));
  if (name == "ellipsoid") return std::make_unique<Ellipsoid>(get("a"), get("b"), get("c"));
  return std::make_unique<Torus>(get("R"), get("r"));
}

}  // namespace digilap::surface
