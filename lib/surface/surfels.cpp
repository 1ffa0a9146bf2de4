#include "digilap/surface/surfels.hpp"

#include "core/union_find.hpp"

#include <algorithm>
#include <numeric>
#include <unordered_map>

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

std::vector<std::size_t> SurfelSet::offsets() const {
  if (!surface_offset.empty()) return surface_offset;
  return {0, size()};
}

namespace detail {
std::int64_t twice_enclosed_voxels(const SurfelSet& surfels, std::size_t first, std::size_t last) {
  // With the field (x, 0, 0): the sum over the x-faces of sign (x + sign / 2) = (2 sign x + 1) / 2 voxels.
  std::int64_t twice = 0;
  for (std::size_t s = first; s < last; ++s) {
    const Surfel& f = surfels.surfels[s];
    if (f.axis == 0) twice += 2 * f.sign * static_cast<std::int64_t>(f.voxel.x()) + 1;
  }
  return twice;
}
}  // namespace detail

double enclosed_volume(const SurfelSet& surfels, std::size_t first, std::size_t last) {
  return 0.5 * static_cast<double>(detail::twice_enclosed_voxels(surfels, first, last)) * surfels.h * surfels.h * surfels.h;
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

namespace {
// The surfels of the kept components (all when `keep` is empty) grouped by component, in their
// order within each (a stable counting sort), with the offsets.
SurfelSet grouped_by_surface(const SurfelSet& in, const SurfelComponents& components, const std::vector<bool>& keep) {
  SurfelSet out;
  out.h = in.h;
  std::vector<std::size_t> start(components.sizes.size() + 1, 0);
  for (std::size_t c = 0; c < components.sizes.size(); ++c)
    start[c + 1] = start[c] + (keep.empty() || keep[c] ? components.sizes[c] : 0);
  out.surfels.resize(start.back());
  std::vector<std::size_t> fill(start.begin(), start.end() - 1);
  for (std::size_t s = 0; s < in.size(); ++s) {
    const auto c = static_cast<std::size_t>(components.of_surfel[s]);
    if (keep.empty() || keep[c]) out.surfels[fill[c]++] = in.surfels[s];
  }
  out.surface_offset.push_back(0);
  for (std::size_t c = 0; c < components.sizes.size(); ++c)
    if (keep.empty() || keep[c]) out.surface_offset.push_back(start[c + 1]);
  return out;
}
}  // namespace

namespace detail {
SurfelSet surfels_in_row_order(const VoxelSet& set) {
  SurfelSet out;
  out.h = set.h();
  const std::int64_t nj = set.j_end() - set.j_begin(), nk = set.k_end() - set.k_begin(), rows = nj * nk;
  std::vector<std::vector<Surfel>> per_row(static_cast<std::size_t>(std::max<std::int64_t>(rows, 0)));
#pragma omp parallel for schedule(dynamic, 64)
  for (std::int64_t r = 0; r < rows; ++r) {
    const std::int32_t j = set.j_begin() + static_cast<std::int32_t>(r % nj), k = set.k_begin() + static_cast<std::int32_t>(r / nj);
    const Run* b = set.row_runs_begin(j, k);
    const Run* e = set.row_runs_end(j, k);
    if (b == e) continue;
    std::vector<Surfel>& found = per_row[static_cast<std::size_t>(r)];
    for (const Run* run = b; run != e; ++run) {
      found.push_back({{run->begin, j, k}, 0, -1});
      found.push_back({{run->end - 1, j, k}, 0, 1});
    }
    const std::int32_t neighbour[4][2] = {{j - 1, k}, {j + 1, k}, {j, k - 1}, {j, k + 1}};
    const std::int8_t axis[4] = {1, 1, 2, 2}, sign[4] = {-1, 1, -1, 1};
    for (int n = 0; n < 4; ++n)
      for_each_uncovered(b, e, set.row_runs_begin(neighbour[n][0], neighbour[n][1]), set.row_runs_end(neighbour[n][0], neighbour[n][1]),
                         [&](std::int32_t i) { found.push_back({{i, j, k}, axis[n], sign[n]}); });
  }
  std::size_t total = 0;
  for (const auto& row : per_row) total += row.size();
  out.surfels.reserve(total);
  for (const auto& row : per_row) out.surfels.insert(out.surfels.end(), row.begin(), row.end());
  return out;
}
}  // namespace detail

SurfelSet extract_surfels(const VoxelSet& set) {
  const SurfelSet out = detail::surfels_in_row_order(set);
  return grouped_by_surface(out, connected_surfaces(set, out), {});
}

namespace {
struct SurfelKey {
  std::uint64_t operator()(const Surfel& f) const {
    auto part = [](std::int32_t v) { return static_cast<std::uint64_t>(static_cast<std::uint32_t>(v) & 0x1fffffu); };
    return part(f.voxel.x()) ^ (part(f.voxel.y()) << 21) ^ (part(f.voxel.z()) << 42) ^
           (static_cast<std::uint64_t>(f.axis * 2 + (f.sign > 0)) << 61);
  }
};
struct SurfelEqual {
  bool operator()(const Surfel& a, const Surfel& b) const { return a.voxel == b.voxel && a.axis == b.axis && a.sign == b.sign; }
};
}  // namespace

SurfelComponents connected_surfaces(const VoxelSet& set, const SurfelSet& surfels) {
  const std::size_t n = surfels.size();
  std::unordered_map<Surfel, std::size_t, SurfelKey, SurfelEqual> index;
  index.reserve(n);
  for (std::size_t s = 0; s < n; ++s) index.emplace(surfels.surfels[s], s);
  digilap::detail::UnionFind trees(n);
  auto inside = [&](const Eigen::Vector3i& v) { return set.contains(v.x(), v.y(), v.z()); };
  for (std::size_t s = 0; s < n; ++s) {
    const Surfel& f = surfels.surfels[s];
    for (int c = 0; c < 3; ++c) {
      if (c == f.axis) continue;
      for (int d : {-1, 1}) {
        Eigen::Vector3i side = f.voxel, diagonal;
        side[c] += d;
        diagonal = side;
        diagonal[f.axis] += f.sign;
        Surfel next;
        if (inside(side) && inside(diagonal)) next = {diagonal, static_cast<std::int8_t>(c), static_cast<std::int8_t>(-d)};  // concave
        else if (inside(side)) next = {side, f.axis, f.sign};                                                                // flat
        else next = {f.voxel, static_cast<std::int8_t>(c), static_cast<std::int8_t>(d)};                                     // convex
        const auto it = index.find(next);
        if (it == index.end()) continue;  // cannot happen on a set's own surfels
        trees.join(s, it->second);
      }
    }
  }
  SurfelComponents out;
  out.of_surfel.assign(n, -1);
  for (std::size_t s = 0; s < n; ++s) {
    const std::size_t r = trees.root(s);
    if (r == s) {
      out.of_surfel[s] = static_cast<int>(out.sizes.size());
      out.sizes.push_back(0);
    } else {
      out.of_surfel[s] = out.of_surfel[r];
    }
    ++out.sizes[static_cast<std::size_t>(out.of_surfel[s])];
  }
  return out;
}

FilteredSurfels filter_surfels(const VoxelSet& set, const SurfelSet& surfels, const SurfelFilter& filter) {
  const SurfelComponents components = connected_surfaces(set, surfels);
  std::vector<bool> keep(components.sizes.size());
  const auto largest = static_cast<std::size_t>(
      std::max_element(components.sizes.begin(), components.sizes.end()) - components.sizes.begin());
  for (std::size_t c = 0; c < keep.size(); ++c)
    keep[c] = components.sizes[c] >= filter.min_surfels && (!filter.largest_only || c == largest);
  FilteredSurfels out;
  out.surfels = grouped_by_surface(surfels, components, keep);
  out.dropped = static_cast<std::size_t>(std::count(keep.begin(), keep.end(), false));
  return out;
}

}  // namespace digilap::surface
