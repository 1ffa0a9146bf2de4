#include "digilap/surface/surfels.hpp"

#include <algorithm>

namespace digilap::surface {

Eigen::Vector3d SurfelSet::centre(std::size_t s) const {
  const Surfel& f = surfels[s];
  Eigen::Vector3d c = f.voxel.cast<double>();
  c[f.axis] += 0.5 * f.sign;
  return h * c;
}

Eigen::Vector3d SurfelSet::trivial_normal(std::size_t s) const {
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  n[surfels[s].axis] = surfels[s].sign;
  return n;
}

Eigen::MatrixX3d SurfelSet::centres() const {
  Eigen::MatrixX3d c(static_cast<Eigen::Index>(size()), 3);
  for (std::size_t s = 0; s < size(); ++s) c.row(static_cast<Eigen::Index>(s)) = centre(s).transpose();
  return c;
}

namespace {
// Calls f(i) for every i in the runs [a, b) that the runs [c, d) do not cover (both sorted).
template <class F>
void for_each_uncovered(const Run* a, const Run* b, const Run* c, const Run* d, F&& f) {
  for (; a != b; ++a) {
    std::int32_t i = a->begin;
    const Run* o = std::upper_bound(c, d, i, [](std::int32_t v, const Run& r) { return v < r.end; });  // first run ending after i
    while (i < a->end) {
      if (o == d || o->begin >= a->end) {
        for (; i < a->end; ++i) f(i);
        break;
      }
      for (; i < std::min(o->begin, a->end); ++i) f(i);
      i = std::max(i, o->end);
      ++o;
    }
  }
}
}  // namespace

SurfelSet extract_surfels(const VoxelSet& set) {
  SurfelSet out;
  out.h = set.h();
  const std::int64_t nj = set.j_end() - set.j_begin(), nk = set.k_end() - set.k_begin(), rows = nj * nk;
  std::vector<std::vector<Surfel>> per_row(static_cast<std::size_t>(std::max<std::int64_t>(rows, 0)));
#pragma omp parallel for schedule(dynamic, 64)
  for (std::int64_t r = 0; r < rows; ++r) {
    const std::int32_t j = set.j_begin() + static_cast<std::int32_t>(r % nj), k = set.k_begin() + static_cast<std::int32_t>(r / nj);
    const Run* b = set.row_begin(j, k);
    const Run* e = set.row_end(j, k);
    if (b == e) continue;
    std::vector<Surfel>& found = per_row[static_cast<std::size_t>(r)];
    for (const Run* run = b; run != e; ++run) {
      found.push_back({{run->begin, j, k}, 0, -1});
      found.push_back({{run->end - 1, j, k}, 0, 1});
    }
    const std::int32_t neighbour[4][2] = {{j - 1, k}, {j + 1, k}, {j, k - 1}, {j, k + 1}};
    const std::int8_t axis[4] = {1, 1, 2, 2}, sign[4] = {-1, 1, -1, 1};
    for (int n = 0; n < 4; ++n)
      for_each_uncovered(b, e, set.row_begin(neighbour[n][0], neighbour[n][1]), set.row_end(neighbour[n][0], neighbour[n][1]),
                         [&](std::int32_t i) { found.push_back({{i, j, k}, axis[n], sign[n]}); });
  }
  std::size_t total = 0;
  for (const auto& row : per_row) total += row.size();
  out.surfels.reserve(total);
  for (const auto& row : per_row) out.surfels.insert(out.surfels.end(), row.begin(), row.end());
  return out;
}

}  // namespace digilap::surface
