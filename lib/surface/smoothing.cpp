#include "digilap/surface/smoothing.hpp"

#include "digilap/core/error.hpp"
#include "digilap/core/smoothing.hpp"
#include "core/components.hpp"

#include <cmath>

namespace digilap::surface {

namespace {
// Area-weighted centroid and RMS distance to it of the rows `rows`.
std::pair<Eigen::RowVector3d, double> centroid_and_rms(const Eigen::MatrixX3d& p, const Eigen::VectorXd& mass,
                                                       const std::vector<Eigen::Index>& rows) {
  Eigen::RowVector3d c = Eigen::RowVector3d::Zero();
  double m = 0;
  for (Eigen::Index r : rows) c += mass[r] * p.row(r), m += mass[r];
  c /= m;
  double sum = 0;
  for (Eigen::Index r : rows) sum += mass[r] * (p.row(r) - c).squaredNorm();
  return {c, std::sqrt(sum / m)};
}
}  // namespace

Eigen::MatrixX3d smooth_positions(const SurfaceOperator& op, const SurfaceSmoothingOptions& o) {
  Eigen::MatrixX3d p = smooth(op, op.positions, o.tau, o.steps);
  if (o.preserve_size)
    for (const std::vector<Eigen::Index>& rows : digilap::detail::connected_components(op.A).rows) {
      const auto [before_centre, before] = centroid_and_rms(op.positions, op.mass, rows);
      const auto [centre, after] = centroid_and_rms(p, op.mass, rows);
      if (!(after > 0)) continue;  // collapsed to a point: nothing sensible to rescale
      for (Eigen::Index r : rows) p.row(r) = (p.row(r) - centre) * (before / after) + centre;
    }
  return p;
}

}  // namespace digilap::surface
