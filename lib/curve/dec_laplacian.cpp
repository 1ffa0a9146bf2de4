// The DEC (cotan-like) baseline on the pointels of closed contours: what does not converge.
#include "digilap/curve/heat_laplacian.hpp"

#include "elements.hpp"

#include <Eigen/SparseCore>

#include <vector>

namespace digilap {
inline namespace curve {

using detail::Elements;
using detail::gather_elements;

ContourOperator dec_laplacian(const ContourSet& contours, const Measures& measures, DecLengths lengths,
                              std::size_t* clamped_lengths) {
  const Elements e = gather_elements(contours, measures, Placement::Pointels);
  const Eigen::Index n = e.offset.back();
  const double floor_length = 1e-6 * contours.h;
  std::size_t clamped = 0;
  std::vector<Eigen::Triplet<double>> tl, ta;  // 3 entries per row: a triplet list is fine here
  Eigen::VectorXd mass(n);
  for (std::size_t c = 0; c + 1 < e.offset.size(); ++c) {
    const Eigen::Index off = e.offset[c], len = e.offset[c + 1] - off;
    Eigen::VectorXd edge(len);  // length of linel l_i
    for (Eigen::Index i = 0; i < len; ++i) {
      edge[i] = lengths == DecLengths::Naive ? contours.h : measures.contours[c].linel_mu[i];
      if (edge[i] < floor_length) edge[i] = floor_length, ++clamped;
    }
    for (Eigen::Index i = 0; i < len; ++i) {
      const Eigen::Index r = off + i, ip = (i + len - 1) % len, in = (i + 1) % len;
      const double wp = 1.0 / edge[ip], wn = 1.0 / edge[i];
      mass[r] = 0.5 * (edge[ip] + edge[i]);
      tl.emplace_back(r, off + ip, wp / mass[r]);
      tl.emplace_back(r, off + in, wn / mass[r]);
      tl.emplace_back(r, r, -(wp + wn) / mass[r]);
      ta.emplace_back(r, off + ip, wp);
      ta.emplace_back(r, off + in, wn);
      ta.emplace_back(r, r, -(wp + wn));
    }
  }
  ContourOperator op;
  op.L.resize(n, n);
  op.L.setFromTriplets(tl.begin(), tl.end());
  op.A.resize(n, n);
  op.A.setFromTriplets(ta.begin(), ta.end());
  op.M = detail::diagonal_matrix(mass);
  op.mass = mass;
  op.positions = e.positions;
  op.arclength = e.s;
  op.row_offset = e.offset;
  op.contour_length = e.length;
  if (clamped_lengths) *clamped_lengths = clamped;
  return op;
}

}  // namespace curve
}  // namespace digilap
