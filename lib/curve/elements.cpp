#include "elements.hpp"

#include "digilap/core/error.hpp"

namespace digilap::detail {

Elements gather_elements(const ContourSet& contours, const Measures& measures, Placement placement) {
  if (measures.contours.size() != contours.contours.size())
    throw Error("heat_laplacian: measures are given for " + std::to_string(measures.contours.size()) +
                " contours, but there are " + std::to_string(contours.contours.size()));
  Elements e;
  for (std::size_t c = 0; c < contours.contours.size(); ++c) {
    if (static_cast<std::size_t>(measures.contours[c].linel_mu.size()) != contours.contours[c].size())
      throw Error("heat_laplacian: the measures of contour " + std::to_string(c) + " do not match its size");
    e.offset.push_back(e.offset.back() + static_cast<Eigen::Index>(contours.contours[c].size()));
  }
  const Eigen::Index n = e.offset.back();
  e.positions.resize(n, 2);
  e.mu.resize(n);
  e.s.resize(n);
  for (std::size_t c = 0; c < contours.contours.size(); ++c) {
    const ContourMeasures& m = measures.contours[c];
    e.length.push_back(m.length);
    for (Eigen::Index i = 0; i < m.S.size(); ++i) {
      const Eigen::Index r = e.offset[c] + i;
      if (placement == Placement::Pointels) {
        e.positions.row(r) = contours.pointel_position(c, i).transpose();
        e.mu[r] = m.vertex_mu[i];
        e.s[r] = m.S[i];
      } else {
        e.positions.row(r) = contours.linel_midpoint(c, i).transpose();
        e.mu[r] = m.linel_mu[i];
        e.s[r] = m.S[i] + 0.5 * m.linel_mu[i];  // SPEC §4: the midpoint of l_i along the contour
      }
    }
  }
  return e;
}

GeodesicWindow geodesic_window(const double* s, Eigen::Index n, Eigen::Index i, double P, double cut) {
  GeodesicWindow w;
  if (n <= 1) return w;
  if (cut >= 0.5 * P) {  // the window covers the contour: every other element, once
    w.fwd = n - 1;
    return w;
  }
  // Forward offsets (s_j - s_i, + P after the wrap) grow with j: binary search the last one
  // within the cut, then settle the boundary with the symmetric distance itself.
  auto fwd_offset = [&](Eigen::Index m) {
    const Eigen::Index j = i + m;
    return j < n ? s[j] - s[i] : s[j - n] + P - s[i];
  };
  Eigen::Index lo = 0, hi = n - 1;  // invariant: offset(lo) <= cut (offset(0) = 0)
  while (lo < hi) {
    const Eigen::Index mid = (lo + hi + 1) / 2;
    if (fwd_offset(mid) <= cut) lo = mid; else hi = mid - 1;
  }
  auto dist_fwd = [&](Eigen::Index m) { return cyclic_distance(s[i], s[(i + m) % n], P); };
  while (lo > 0 && dist_fwd(lo) > cut) --lo;
  while (lo + 1 <= n - 1 && dist_fwd(lo + 1) <= cut) ++lo;
  w.fwd = lo;
  auto back_offset = [&](Eigen::Index m) {
    const Eigen::Index j = i - m;
    return j >= 0 ? s[i] - s[j] : s[i] + P - s[j + n];
  };
  const Eigen::Index max_back = n - 1 - w.fwd;
  lo = 0, hi = max_back;
  while (lo < hi) {
    const Eigen::Index mid = (lo + hi + 1) / 2;
    if (back_offset(mid) <= cut) lo = mid; else hi = mid - 1;
  }
  auto dist_back = [&](Eigen::Index m) { return cyclic_distance(s[i], s[((i - m) % n + n) % n], P); };
  while (lo > 0 && dist_back(lo) > cut) --lo;
  while (lo + 1 <= max_back && dist_back(lo + 1) <= cut) ++lo;
  w.back = lo;
  return w;
}

}  // namespace digilap::detail
