// digilap — closed surfaces with exact geometry, the 3D reference shapes (SPEC §7): sphere,
// ellipsoid, torus, each with a pose. The surface sibling of curve/shapes.hpp.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace digilap::surface {

class Surface {
public:
  virtual ~Surface() = default;
  virtual std::string name() const = 0;
  /// Exact area.
  virtual double area() const = 0;

  /// Moves the surface: x -> rotation x + centre (rotation orthonormal, det 1; finite centre).
  /// Throws digilap::Error otherwise.
  void set_pose(const Eigen::Vector3d& centre, const Eigen::Matrix3d& rotation);
  Eigen::Vector3d centre() const { return centre_; }
  Eigen::Matrix3d rotation() const { return rotation_; }
  /// Strictly inside.
  bool inside(const Eigen::Vector3d& p) const;
  /// The point of the surface closest to p (orthogonal projection). Throws for a non-finite p.
  Eigen::Vector3d closest_point(const Eigen::Vector3d& p) const;
  /// Outward unit normal at a point of the surface.
  Eigen::Vector3d normal(const Eigen::Vector3d& on_surface) const;
  /// Mean curvature H = (k1 + k2) / 2 at a point of the surface, > 0 on a sphere (1 / r).
  double mean_curvature(const Eigen::Vector3d& on_surface) const;
  /// A box containing the surface.
  Eigen::AlignedBox3d bounding_box() const;
  /// The intervals of x where the line (x, y, z) is inside, sorted (ends on the surface).
  std::vector<std::pair<double, double>> x_intervals(double y, double z) const;

protected:
  virtual bool local_inside(const Eigen::Vector3d& q) const = 0;
  virtual Eigen::Vector3d local_closest_point(const Eigen::Vector3d& q) const = 0;
  virtual Eigen::Vector3d local_normal(const Eigen::Vector3d& q) const = 0;
  virtual double local_mean_curvature(const Eigen::Vector3d& q) const = 0;
  virtual Eigen::Vector3d local_half_extent() const = 0;
  /// Roots s of the surface's implicit function along q0 + s d, sorted.
  virtual std::vector<double> local_crossings(const Eigen::Vector3d& q0, const Eigen::Vector3d& d) const = 0;

private:
  Eigen::Vector3d centre_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d rotation_ = Eigen::Matrix3d::Identity();
};

/// Sphere of radius r (default 1).
class Sphere : public Surface {
public:
  explicit Sphere(double r = 1.0);
  std::string name() const override { return "sphere"; }
  double area() const override;

protected:
  bool local_inside(const Eigen::Vector3d& q) const override;
  Eigen::Vector3d local_closest_point(const Eigen::Vector3d& q) const override;
  Eigen::Vector3d local_normal(const Eigen::Vector3d& q) const override;
  double local_mean_curvature(const Eigen::Vector3d& q) const override;
  Eigen::Vector3d local_half_extent() const override;
  std::vector<double> local_crossings(const Eigen::Vector3d& q0, const Eigen::Vector3d& d) const override;

private:
  double r_;
};

/// Ellipsoid with semi-axes a, b, c along x, y, z (defaults 1.2, 1.0, 0.8, SPEC §7).
class Ellipsoid : public Surface {
public:
  explicit Ellipsoid(double a = 1.2, double b = 1.0, double c = 0.8);
  std::string name() const override { return "ellipsoid"; }
  double area() const override { return area_; }

protected:
  bool local_inside(const Eigen::Vector3d& q) const override;
  Eigen::Vector3d local_closest_point(const Eigen::Vector3d& q) const override;
  Eigen::Vector3d local_normal(const Eigen::Vector3d& q) const override;
  double local_mean_curvature(const Eigen::Vector3d& q) const override;
  Eigen::Vector3d local_half_extent() const override { return axes_; }
  std::vector<double> local_crossings(const Eigen::Vector3d& q0, const Eigen::Vector3d& d) const override;

private:
  Eigen::Vector3d axes_;
  double area_ = 0;
};

/// Torus around the z axis: ring radius R, tube radius r < R (defaults 1, 0.4, SPEC §7).
class Torus : public Surface {
public:
  explicit Torus(double R = 1.0, double r = 0.4);
  std::string name() const override { return "torus"; }
  double area() const override;

protected:
  bool local_inside(const Eigen::Vector3d& q) const override;
  Eigen::Vector3d local_closest_point(const Eigen::Vector3d& q) const override;
  Eigen::Vector3d local_normal(const Eigen::Vector3d& q) const override;
  double local_mean_curvature(const Eigen::Vector3d& q) const override;
  Eigen::Vector3d local_half_extent() const override { return {R_ + r_, R_ + r_, r_}; }
  std::vector<double> local_crossings(const Eigen::Vector3d& q0, const Eigen::Vector3d& d) const override;

private:
  double R_, r_;
};

/// The reference surfaces by name ("sphere", "ellipsoid", "torus"), with their own parameters
/// after a colon as for curves ("sphere:r=2", "ellipsoid:a=1.2,b=1,c=0.8", "torus:R=1,r=0.4").
/// Throws digilap::Error for an unknown name or key (listing the known ones), as make_shape().
std::unique_ptr<Surface> make_surface(const std::string& spec);
/// The names make_surface() knows, and one line per surface with its keys and their defaults
/// (SPEC §7's reference parameters; for --help), as curve::shape_names() and shape_syntax().
std::vector<std::string> surface_names();
std::string surface_syntax();

}  // namespace digilap::surface
