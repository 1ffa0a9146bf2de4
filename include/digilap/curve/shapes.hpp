// digilap — parametric closed curves with exact geometry (SPEC §6).
//
// A Shape is a simple closed curve gamma(theta), theta in [-pi, pi), run counter-clockwise, with
// its interior. Every quantity is exact up to floating point: derivatives are analytic, the
// arclength is a composite Gauss-Legendre quadrature (1e-12 relative or better), the closest
// point is a safeguarded Newton iteration started from a dense sampling of the curve.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace digilap {
inline namespace curve {

class Shape {
public:
  virtual ~Shape();

  /// Curve point, first and second derivatives with respect to theta, in world coordinates.
  Eigen::Vector2d point(double theta) const;
  Eigen::Vector2d derivative(double theta) const;
  Eigen::Vector2d second_derivative(double theta) const;

  /// Unit tangent (direction of increasing theta) and unit outward normal at gamma(theta).
  Eigen::Vector2d tangent(double theta) const;
  Eigen::Vector2d outward_normal(double theta) const;
  /// Signed curvature (> 0 where the curve is convex).
  double curvature(double theta) const;

  /// Strict inside test: true for points of the open interior.
  bool inside(const Eigen::Vector2d& p) const;

  /// Arclength from theta = -pi to theta (theta in [-pi, pi]); length() = arclength(pi).
  double arclength(double theta) const;
  double length() const { return length_; }

  /// Parameter theta of the orthogonal projection of p on the curve (the closest point).
  /// Robust for any p: a nearest-sample search over a dense sampling picks the basin, a
  /// safeguarded Newton iteration on <gamma - p, gamma'> = 0 refines it to machine precision.
  double closest_parameter(const Eigen::Vector2d& p) const;

  /// Parameter of the curve point seen from the centre in the direction of p (the radial
  /// projection; the curves here are star-shaped around their centre).
  double radial_parameter(const Eigen::Vector2d& p) const;

  /// Axis-aligned bounding box of the curve (from the dense sampling, padded by its error).
  Eigen::AlignedBox2d bounding_box() const { return bbox_; }

  /// Rigid placement: the curve is rotated by `rotation` radians about its own origin, then
  /// moved so that its origin sits at `centre`. Default: centre (0, 0), rotation 0.
  void set_pose(const Eigen::Vector2d& centre, double rotation);
  Eigen::Vector2d centre() const { return centre_; }
  double rotation() const { return rotation_; }

  virtual std::string name() const = 0;

  /// Dense sampling used for the closest-point search and the digitization (theta values
  /// uniform in [-pi, pi), positions in world coordinates).
  const std::vector<double>& sample_parameters() const { return sample_theta_; }
  const std::vector<Eigen::Vector2d>& sample_points() const { return sample_point_; }

protected:
  Shape() = default;
  /// Subclasses call this at the end of their constructor (and after any parameter change).
  void initialize();

  // The curve in its own frame (centre 0, rotation 0).
  virtual Eigen::Vector2d local_point(double theta) const = 0;
  virtual Eigen::Vector2d local_derivative(double theta) const = 0;
  virtual Eigen::Vector2d local_second_derivative(double theta) const = 0;
  virtual bool local_inside(const Eigen::Vector2d& p) const = 0;
  /// Parameter of the curve point at polar angle phi in the shape's frame (phi itself for polar curves).
  virtual double local_polar_parameter(double phi) const { return phi; }

private:
  Eigen::Vector2d to_world(const Eigen::Vector2d& v) const;     // rotate + translate
  Eigen::Vector2d rotate(const Eigen::Vector2d& v) const;       // rotate only
  Eigen::Vector2d to_local(const Eigen::Vector2d& p) const;
  double speed(double theta) const { return derivative(theta).norm(); }
  void build_sampling();
  void build_arclength_table();
  void build_sample_grid();
  size_t nearest_sample(const Eigen::Vector2d& p) const;

  Eigen::Vector2d centre_ = Eigen::Vector2d::Zero();
  double rotation_ = 0.0;
  double length_ = 0.0;
  Eigen::AlignedBox2d bbox_;
  std::vector<double> sample_theta_;
  std::vector<Eigen::Vector2d> sample_point_;
  std::vector<double> panel_arclength_;  // arclength at the start of each quadrature panel
  // Uniform bucket grid over the samples, for nearest-sample queries.
  double grid_cell_ = 0.0;
  Eigen::Vector2d grid_origin_;
  int grid_nx_ = 0, grid_ny_ = 0;
  std::vector<int> grid_start_, grid_items_;
};

/// Polar curve r = r(theta) around the origin, from user callables for r, r' and r''.
/// Requires r > 0 everywhere (star-shaped); the inside test is |p| < r(atan2(p)).
class PolarCurve : public Shape {
public:
  using Function = std::function<double(double)>;
  PolarCurve(Function r, Function dr, Function d2r, std::string name = "polar");
  std::string name() const override { return name_; }
  double radius(double theta) const { return r_(theta); }

protected:
  PolarCurve() = default;
  void set_functions(Function r, Function dr, Function d2r);
  Eigen::Vector2d local_point(double theta) const override;
  Eigen::Vector2d local_derivative(double theta) const override;
  Eigen::Vector2d local_second_derivative(double theta) const override;
  bool local_inside(const Eigen::Vector2d& p) const override;

  std::string name_ = "polar";

private:
  Function r_, dr_, d2r_;
};

/// Circle r = radius (default 1).
class Circle : public PolarCurve {
public:
  explicit Circle(double radius = 1.0);
};

/// Ellipse x = a cos(theta), y = b sin(theta) (defaults a = 2, b = 1).
class Ellipse : public Shape {
public:
  explicit Ellipse(double a = 2.0, double b = 1.0);
  std::string name() const override { return "ellipse"; }

protected:
  Eigen::Vector2d local_point(double theta) const override;
  Eigen::Vector2d local_derivative(double theta) const override;
  Eigen::Vector2d local_second_derivative(double theta) const override;
  bool local_inside(const Eigen::Vector2d& p) const override;
  double local_polar_parameter(double phi) const override;

private:
  double a_, b_;
};

/// Flower r = R + v cos(k theta + phi) (defaults R = 2, v = 0.5, k = 5, phi = 0).
class Flower : public PolarCurve {
public:
  explicit Flower(double R = 2.0, double v = 0.5, int k = 5, double phi = 0.0);
};

/// Accelerated flower r = R + v cos(K' theta^3), K' = 2k / pi^2 (defaults R = 2, v = 0.25, k = 2).
class AccFlower : public PolarCurve {
public:
  explicit AccFlower(double R = 2.0, double v = 0.25, int k = 2);
};

/// The reference shapes by name ("circle", "ellipse", "flower", "accflower") with SPEC §6
/// defaults, or with their own parameters after a colon: "circle:r=2", "ellipse:a=3,b=1",
/// "flower:R=1.5,v=0.3,k=4,phase=0.2", "accflower:R=2,v=0.25,k=3" (keys not given keep their
/// defaults). Throws digilap::Error for an unknown name or key (listing the known ones), a
/// value that is not a number (k: a whole number from 1 to 10^6), a key given twice, or
/// parameters the shape refuses (a radius <= 0, R <= |v|: a curve through its centre).
std::unique_ptr<Shape> make_shape(const std::string& spec);
std::vector<std::string> shape_names();
/// One line per shape: its name and keys with their defaults (for --help).
std::string shape_syntax();

}  // namespace curve
}  // namespace digilap
