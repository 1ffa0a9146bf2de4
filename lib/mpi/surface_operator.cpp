// The distributed surface pipeline (include/digilap/mpi/surface_operator.hpp). Each stage reads
// a slab and computes with the one-machine library on it; what crosses slabs is agreed on by
// small collectives: per-plane surfel counts (balance, numbering), the components that cross a
// slab boundary (union-find over their ids), per-component sums (size, volume, first surfel), the
// sampled radii of curvature (l), and the surface labels of halo surfels (from their owners).
// Why the rows equal the one-machine ones bit for bit: a rank's local set holds, for each of its
// rows, every surfel of the same surface within the cut, in the whole set's order within each
// surface (row order), with the same areas (the II ball lies inside the slab read) and the same
// heat time; surface::heat_laplacian then sums the same terms in the same order.
#include "digilap/mpi/surface_operator.hpp"

#include "collectives.hpp"
#include "core/union_find.hpp"
#include "digilap/core/constants.hpp"
#include "digilap/core/error.hpp"
#include "digilap/core/length_scale.hpp"
#include "digilap/surface/heat_laplacian.hpp"
#include "digilap/surface/measures.hpp"
#include "digilap/surface/normals.hpp"
#include "surface/ball_moments.hpp"
#include "surface/length_scale_parts.hpp"
#include "surface/volume_grid.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <sstream>

namespace digilap::mpi {

using detail::all_gather;
using detail::all_reduce;
using detail::all_to_all;
using detail::on_every_rank;
using detail::petsc_check;
using detail::Ranks;
using surface::Surfel;
using surface::SurfelSet;
using surface::VoxelSet;

DistributedSurfaceOperator::DistributedSurfaceOperator(DistributedSurfaceOperator&& o) noexcept { *this = std::move(o); }
DistributedSurfaceOperator& DistributedSurfaceOperator::operator=(DistributedSurfaceOperator&& o) noexcept {
  if (this == &o) return *this;
  std::swap(L, o.L), std::swap(A, o.A), std::swap(mass, o.mass);
  comm = o.comm, size = o.size, row_begin = o.row_begin, row_end = o.row_end, plane_begin = o.plane_begin, plane_end = o.plane_end;
  halo_planes = o.halo_planes, planes_read = o.planes_read, h = o.h, length_scale = o.length_scale, normal_radius = o.normal_radius;
  surface_t = std::move(o.surface_t), surface_size = std::move(o.surface_size), clamped = o.clamped, dropped_surfaces = o.dropped_surfaces;
  surfels = std::move(o.surfels), surface_of = std::move(o.surface_of), mu = std::move(o.mu), normals = std::move(o.normals);
  return *this;
}
DistributedSurfaceOperator::~DistributedSurfaceOperator() {
  if (L) MatDestroy(&L);
  if (A) MatDestroy(&A);
  if (mass) VecDestroy(&mass);
}
double DistributedSurfaceOperator::t() const {
  std::size_t largest = 0;
  for (std::size_t c = 0; c < surface_size.size(); ++c)
    if (surface_size[c] > surface_size[largest]) largest = c;
  return surface_t.empty() ? 0.0 : surface_t[largest];
}

namespace {

// Stage timings on stderr from rank 0 (the long runs' progress).
struct Stages {
  const Ranks& ranks;
  bool quiet;
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  void done(const std::string& what) const {
    if (quiet || ranks.rank != 0) return;
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::fprintf(stderr, "[%7.2f s] %s\n", s, what.c_str());
  }
};

bool in_planes(const Surfel& f, std::int64_t begin, std::int64_t end) { return f.voxel.z() >= begin && f.voxel.z() < end; }

// The surfels of `all` (row order) on planes [begin, end), in row order.
SurfelSet on_planes(const SurfelSet& all, std::int64_t begin, std::int64_t end) {
  SurfelSet out;
  out.h = all.h;
  for (const Surfel& f : all.surfels)
    if (in_planes(f, begin, end)) out.surfels.push_back(f);
  return out;
}

// Planes of each rank: [bounds[r], bounds[r + 1]), about total / P surfels each.
std::vector<std::int64_t> balanced_bounds(const std::vector<std::int64_t>& per_plane, int ranks) {
  const std::int64_t nz = static_cast<std::int64_t>(per_plane.size());
  const std::int64_t total = std::accumulate(per_plane.begin(), per_plane.end(), std::int64_t(0));
  std::vector<std::int64_t> bounds(static_cast<std::size_t>(ranks) + 1, nz);
  bounds[0] = 0;
  std::int64_t before = 0, k = 0;  // surfels on the planes < k
  for (int r = 1; r < ranks; ++r) {
    while (k < nz && before * ranks < static_cast<std::int64_t>(r) * total) before += per_plane[static_cast<std::size_t>(k++)];
    bounds[static_cast<std::size_t>(r)] = k;
  }
  return bounds;
}

// Labels from their owners: owner r holds `owned_labels` for its surfels on its planes (row
// order, `owned_plane_start[k - plane_begin]` the first on plane k); rank q asks for the planes
// [want_begin[q], want_end[q]) and receives their labels in row order.
std::vector<int> labels_from_owners(const Ranks& ranks, const std::vector<std::int64_t>& bounds, const std::vector<int>& owned_labels,
                                    const std::vector<std::size_t>& owned_plane_start, const std::vector<std::int64_t>& want_begin,
                                    const std::vector<std::int64_t>& want_end) {
  const std::int64_t mine_begin = bounds[static_cast<std::size_t>(ranks.rank)], mine_end = bounds[static_cast<std::size_t>(ranks.rank) + 1];
  std::vector<std::vector<int>> send(static_cast<std::size_t>(ranks.size));
  for (int q = 0; q < ranks.size; ++q) {
    const std::int64_t b = std::max(want_begin[static_cast<std::size_t>(q)], mine_begin);
    const std::int64_t e = std::min(want_end[static_cast<std::size_t>(q)], mine_end);
    if (b >= e) continue;
    send[static_cast<std::size_t>(q)].assign(owned_labels.begin() + static_cast<std::ptrdiff_t>(owned_plane_start[static_cast<std::size_t>(b - mine_begin)]),
                                             owned_labels.begin() + static_cast<std::ptrdiff_t>(owned_plane_start[static_cast<std::size_t>(e - mine_begin)]));
  }
  return all_to_all(ranks, send);
}

}  // namespace

DistributedSurfaceOperator distributed_surface_operator(MPI_Comm comm, const std::string& path, const DistributedSurfaceOptions& o) {
  const Ranks ranks(comm);
  const Stages stages{ranks, o.quiet};
  if (o.op.couple_surfaces) throw Error("distributed_surface_operator: couple_surfaces is not available across ranks");
  if (o.op.richardson) throw Error("heat_laplacian (surfaces): Richardson extrapolation is not available in 3D");
  if (o.k_R != 0) require_positive("distributed_surface_operator: k_R", o.k_R);
  require_positive("distributed_surface_operator: k", o.op.k);
  if (o.length_scale != 0) require_positive("distributed_surface_operator: length_scale", o.length_scale);
  const surface::VolumeInfo info = on_every_rank(ranks, [&] { return surface::read_volume_info(path, o.volume); });
  const std::int64_t nz = info.nz;
  const double h = info.h;
  const auto plane_index = [](const Surfel& f) { return static_cast<std::size_t>(f.voxel.z()); };

  // 1. Balance: an equal share of planes each, surfels counted per plane, then planes by surfels.
  std::vector<std::int64_t> per_plane(static_cast<std::size_t>(nz), 0);
  on_every_rank(ranks, [&] {
    const std::int64_t b = nz * ranks.rank / ranks.size, e = nz * (ranks.rank + 1) / ranks.size;
    const SurfelSet all = surface::detail::surfels_in_row_order(surface::read_volume_slab(path, b - 1, e + 1, o.volume));
    for (const Surfel& f : all.surfels)
      if (in_planes(f, b, e)) ++per_plane[plane_index(f)];
    return 0;
  });
  all_reduce(ranks, per_plane, MPI_SUM);
  if (std::accumulate(per_plane.begin(), per_plane.end(), std::int64_t(0)) == 0)
    throw Error("cannot read volume '" + path + "': " + surface::detail::no_foreground_reason(o.volume));
  const std::vector<std::int64_t> bounds = balanced_bounds(per_plane, ranks.size);
  const std::int64_t k0 = bounds[static_cast<std::size_t>(ranks.rank)], k1 = bounds[static_cast<std::size_t>(ranks.rank) + 1];
  std::vector<std::int64_t> plane_first(static_cast<std::size_t>(nz) + 1, 0);  // row-order index of each plane's first surfel
  for (std::int64_t k = 0; k < nz; ++k) plane_first[static_cast<std::size_t>(k) + 1] = plane_first[static_cast<std::size_t>(k)] + per_plane[static_cast<std::size_t>(k)];
  stages.done("balanced: " + std::to_string(plane_first.back()) + " surfels on " + std::to_string(nz) + " planes");

  // 2. Components. Surfels on [k0 - 1, k1 + 1) have all their neighbours' voxels in the slab
  // [k0 - 2, k1 + 2): their local components are exact pieces of the global ones. Two
  // consecutive ranks both hold the planes k1 - 1 and k1, whose surfels tie their pieces together.
  struct Structure {
    std::int64_t voxels = 0;             // voxels on this rank's planes
    std::vector<Surfel> owned;           // surfels on [k0, k1), row order
    std::vector<std::int64_t> owned_id;  // their piece (global id)
    std::vector<std::int64_t> pairs;     // (piece, piece) ties with the previous rank
    std::int64_t pieces = 0;
  };
  Structure st = on_every_rank(ranks, [&] {
    Structure s;
    const VoxelSet slab = surface::read_volume_slab(path, k0 - 2, k1 + 2, o.volume);
    for (std::int64_t k = k0; k < k1; ++k)
      for (std::int32_t j = slab.j_begin(); j < slab.j_end(); ++j)
        for (const Run* run = slab.row_runs_begin(j, static_cast<std::int32_t>(k)); run != slab.row_runs_end(j, static_cast<std::int32_t>(k)); ++run)
          s.voxels += run->end - run->begin;
    const SurfelSet exact = on_planes(surface::detail::surfels_in_row_order(slab), k0 - 1, k1 + 1);
    const surface::SurfelComponents pieces = surface::connected_surfaces(slab, exact);
    s.pieces = static_cast<std::int64_t>(pieces.sizes.size());
    std::int64_t first_id = 0;
    MPI_Exscan(&s.pieces, &first_id, 1, MPI_INT64_T, MPI_SUM, comm);
    if (ranks.rank == 0) first_id = 0;
    std::vector<std::int64_t> to_next, mine_low;  // ids on planes {k1 - 1, k1}, and on {k0 - 1, k0}
    for (std::size_t q = 0; q < exact.size(); ++q) {
      const Surfel& f = exact.surfels[q];
      const std::int64_t id = first_id + pieces.of_surfel[q];
      if (in_planes(f, k0, k1)) s.owned.push_back(f), s.owned_id.push_back(id);
      if (in_planes(f, k1 - 1, k1 + 1)) to_next.push_back(id);
      if (in_planes(f, k0 - 1, k0 + 1)) mine_low.push_back(id);
    }
    std::vector<std::int64_t> from_previous(mine_low.size());
    const int next = ranks.rank + 1 < ranks.size ? ranks.rank + 1 : MPI_PROC_NULL, previous = ranks.rank > 0 ? ranks.rank - 1 : MPI_PROC_NULL;
    std::int64_t count_out = static_cast<std::int64_t>(to_next.size()), count_in = 0;
    MPI_Sendrecv(&count_out, 1, MPI_INT64_T, next, 1, &count_in, 1, MPI_INT64_T, previous, 1, comm, MPI_STATUS_IGNORE);
    from_previous.resize(static_cast<std::size_t>(ranks.rank > 0 ? count_in : 0));
    MPI_Sendrecv(to_next.data(), static_cast<int>(to_next.size()), MPI_INT64_T, next, 2, from_previous.data(),
                 static_cast<int>(from_previous.size()), MPI_INT64_T, previous, 2, comm, MPI_STATUS_IGNORE);
    if (ranks.rank > 0 && from_previous.size() != mine_low.size())
      throw Error("distributed_surface_operator: two ranks see a different number of surfels on a shared plane (internal error)");
    for (std::size_t q = 0; q < from_previous.size(); ++q) s.pairs.push_back(from_previous[q]), s.pairs.push_back(mine_low[q]);
    return s;
  });
  const std::int64_t pieces_total = all_reduce(ranks, st.pieces, MPI_SUM);
  const std::vector<std::int64_t> pairs = all_gather(ranks, st.pairs);
  digilap::detail::UnionFind trees(static_cast<std::size_t>(pieces_total));
  for (std::size_t p = 0; p + 1 < pairs.size(); p += 2) trees.join(static_cast<std::size_t>(pairs[p]), static_cast<std::size_t>(pairs[p + 1]));
  // Per component (indexed by root piece): surfels, first surfel (row order), twice the enclosed voxels.
  std::vector<std::int64_t> count(static_cast<std::size_t>(pieces_total), 0), twice(count.size(), 0);
  std::vector<std::int64_t> first(count.size(), std::numeric_limits<std::int64_t>::max());
  std::vector<std::size_t> owned_root(st.owned.size());
  {
    std::vector<std::int64_t> seen(static_cast<std::size_t>(nz), 0);
    for (std::size_t q = 0; q < st.owned.size(); ++q) {
      const Surfel& f = st.owned[q];
      const std::size_t root = trees.root(static_cast<std::size_t>(st.owned_id[q]));
      owned_root[q] = root;
      ++count[root];
      first[root] = std::min(first[root], plane_first[plane_index(f)] + seen[plane_index(f)]++);
      if (f.axis == 0) twice[root] += 2 * f.sign * static_cast<std::int64_t>(f.voxel.x()) + 1;
    }
  }
  all_reduce(ranks, count, MPI_SUM);
  all_reduce(ranks, twice, MPI_SUM);
  all_reduce(ranks, first, MPI_MIN);
  // Kept components, numbered by their first surfel (as extract_surfels numbers surfaces).
  std::vector<std::size_t> roots;
  for (std::size_t g = 0; g < count.size(); ++g)
    if (count[g] > 0) roots.push_back(g);
  std::sort(roots.begin(), roots.end(), [&](std::size_t a, std::size_t b) { return first[a] < first[b]; });
  std::size_t largest = roots.empty() ? 0 : roots.front();
  for (std::size_t g : roots)
    if (count[g] > count[largest]) largest = g;  // the first of the largest, as filter_surfels
  std::vector<int> surface_of_root(count.size(), -1);
  DistributedSurfaceOperator out;
  out.comm = comm, out.h = h, out.plane_begin = k0, out.plane_end = k1;
  std::vector<std::int64_t> surface_twice;
  for (std::size_t g : roots) {
    if (static_cast<std::size_t>(count[g]) < o.min_surfels || (o.largest_only && g != largest)) {
      ++out.dropped_surfaces;
      continue;
    }
    surface_of_root[g] = static_cast<int>(out.surface_size.size());
    out.surface_size.push_back(count[g]);
    surface_twice.push_back(twice[g]);
  }
  const std::size_t surfaces = out.surface_size.size();
  if (surfaces == 0)
    throw Error("every surface has fewer than " + std::to_string(o.min_surfels) + " surfels: lower --min-size");
  // Owned labels (row order) and the numbering of the kept surfels, plane by plane.
  std::vector<int> owned_label(st.owned.size());
  std::vector<std::size_t> owned_plane_start(static_cast<std::size_t>(k1 - k0) + 1, 0);
  std::vector<std::int64_t> kept_per_plane(static_cast<std::size_t>(nz), 0);
  for (std::size_t q = 0; q < st.owned.size(); ++q) {
    owned_label[q] = surface_of_root[owned_root[q]];
    ++owned_plane_start[plane_index(st.owned[q]) - static_cast<std::size_t>(k0) + 1];
    if (owned_label[q] >= 0) ++kept_per_plane[plane_index(st.owned[q])];
  }
  std::partial_sum(owned_plane_start.begin(), owned_plane_start.end(), owned_plane_start.begin());
  all_reduce(ranks, kept_per_plane, MPI_SUM);
  std::vector<std::int64_t> kept_first(static_cast<std::size_t>(nz) + 1, 0);
  for (std::int64_t k = 0; k < nz; ++k) kept_first[static_cast<std::size_t>(k) + 1] = kept_first[static_cast<std::size_t>(k)] + kept_per_plane[static_cast<std::size_t>(k)];
  out.size = kept_first.back();
  out.row_begin = kept_first[static_cast<std::size_t>(k0)], out.row_end = kept_first[static_cast<std::size_t>(k1)];
  if (out.size >= std::numeric_limits<PetscInt>::max())
    throw Error("distributed_surface_operator: " + std::to_string(out.size) + " surfels exceed PETSc's 32-bit indices (this build)");
  const std::int64_t voxels_total = all_reduce(ranks, st.voxels, MPI_SUM);
  stages.done(std::to_string(surfaces) + " surface(s) kept, " + std::to_string(out.dropped_surfaces) + " dropped, N = " +
              std::to_string(out.size));

  // 3. The length scale, as surface::length_scale measures it, from the kept surfels' samples.
  std::vector<double> surface_l(surfaces, 0.0);  // l_c in the units of h
  double l = o.length_scale;
  if (l == 0) {
    std::vector<double> size(surfaces);
    double largest_size = 0;
    for (std::size_t c = 0; c < surfaces; ++c) {
      size[c] = surface::detail::equal_volume_radius(surface_twice[c]);
      largest_size = std::max(largest_size, size[c]);
    }
    std::vector<std::int64_t> lo(3, std::numeric_limits<std::int64_t>::max()), hi(3, std::numeric_limits<std::int64_t>::min());
    for (std::size_t q = 0; q < st.owned.size(); ++q) {
      if (owned_label[q] < 0) continue;
      const auto c = surface::detail::doubled_centre(st.owned[q]);
      for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], c[a]), hi[a] = std::max(hi[a], c[a]);
    }
    all_reduce(ranks, lo, MPI_MIN);
    all_reduce(ranks, hi, MPI_MAX);
    const std::array<std::int64_t, 3> lo3{lo[0], lo[1], lo[2]}, hi3{hi[0], hi[1], hi[2]};
    std::vector<std::size_t> sampled;
    for (std::size_t q = 0; q < st.owned.size(); ++q)
      if (owned_label[q] >= 0 && surface::detail::sampled_for_length(st.owned[q], static_cast<std::size_t>(out.size), lo3, hi3))
        sampled.push_back(q);
    const double k_R = LengthScaleOptions{}.k_R;
    double l_voxels = std::max(surface::detail::kLengthFloorVoxels, largest_size);
    // l only falls from its start, so the first round's ball is the widest.
    const auto halo = static_cast<std::int64_t>(std::ceil(surface::detail::length_ball_radius(k_R, l_voxels, largest_size))) + 2;
    const VoxelSet slab = on_every_rank(ranks, [&] { return surface::read_volume_slab(path, k0 - halo, k1 + halo, o.volume); });
    std::vector<std::int64_t> my_surface;
    for (std::size_t q : sampled) my_surface.push_back(owned_label[q]);
    const std::vector<std::int64_t> all_surface = all_gather(ranks, my_surface);
    const std::vector<std::size_t> surface_of(all_surface.begin(), all_surface.end());
    std::vector<std::size_t> surfels_of(surfaces);
    for (std::size_t c = 0; c < surfaces; ++c) surfels_of[c] = static_cast<std::size_t>(out.surface_size[c]);
    std::vector<double> per_surface;
    for (int round = 0; round < surface::detail::kLengthRounds; ++round) {
      const surface::detail::BallRows ball(surface::detail::length_ball_radius(k_R, l_voxels, largest_size));
      std::vector<double> radius(sampled.size());
#pragma omp parallel for schedule(dynamic, 64)
      for (std::size_t q = 0; q < sampled.size(); ++q) radius[q] = surface::detail::ii_radius_of_curvature(slab, st.owned[sampled[q]], ball);
      l_voxels = surface::detail::length_round(all_gather(ranks, radius), surface_of, size, surfels_of, o.length_quantile, per_surface);
    }
    l = l_voxels * h;
    for (std::size_t c = 0; c < surfaces; ++c) surface_l[c] = per_surface[c] > 0 ? per_surface[c] * h : l;  // unsampled: l
    stages.done("length scale l = " + std::to_string(l) + " from " + std::to_string(surface_of.size()) + " samples");
  }
  out.length_scale = l;
  out.normal_radius = surface::ii_ball_radius(o.k_R, h, l);
  const double rho = out.normal_radius / h;
  const double diameter = 2 * std::cbrt(3.0 * static_cast<double>(voxels_total) / (4 * kPi)) + 2;
  if (rho > 2 * diameter) {
    std::ostringstream msg;
    msg << "ii_normals: the ball radius R = " << out.normal_radius << " is wider than the whole set (about " << diameter * h
        << " across): the normals would carry no information; use a smaller k_R";
    throw Error(msg.str());
  }
  // Each surface's heat time, as surface::heat_laplacian's part layout gives it.
  const bool own_l = o.op.per_contour_time && o.op.t == 0 && o.op.length_scale == 0 && o.length_scale == 0;
  double cut = 0;
  out.k = o.op.k;
  for (std::size_t c = 0; c < surfaces; ++c) {
    out.surface_t.push_back(heat_time(h, o.op, own_l ? surface_l[c] : l));
    cut = std::max(cut, o.op.k * std::sqrt(out.surface_t.back()));
  }

  // 4. The rows: the surfels within the cut of this rank's planes, their labels from their
  // owners, their normals from a slab that holds their II balls.
  // The intrinsic kernel weighs column j by a curvature factor from j's own neighbours within
  // the cut: the rows need the surfels within two cuts.
  const std::int64_t cut_planes = (o.op.surface_kernel == SurfaceKernel::Intrinsic ? 2 : 1) * static_cast<std::int64_t>(std::ceil(cut / h)) + 1;
  const auto ball_planes = static_cast<std::int64_t>(std::ceil(rho)) + 2;
  out.halo_planes = cut_planes + ball_planes;
  const std::int64_t near_begin = std::max<std::int64_t>(0, k0 - cut_planes), near_end = std::min(nz, k1 + cut_planes);
  std::vector<std::int64_t> want_begin(static_cast<std::size_t>(ranks.size)), want_end(want_begin.size());
  for (int q = 0; q < ranks.size; ++q) {
    want_begin[static_cast<std::size_t>(q)] = std::max<std::int64_t>(0, bounds[static_cast<std::size_t>(q)] - cut_planes);
    want_end[static_cast<std::size_t>(q)] = std::min(nz, bounds[static_cast<std::size_t>(q) + 1] + cut_planes);
  }
  const std::vector<int> near_label = labels_from_owners(ranks, bounds, owned_label, owned_plane_start, want_begin, want_end);
  struct Rows {
    surface::SurfaceOperator op;
    SurfelSet local;
    std::vector<PetscInt> global;  // global row of each local surfel
    Eigen::MatrixX3d normals;
    std::vector<int> part_surface;  // the kept surface of each part of `local`
  };
  Rows rows = on_every_rank(ranks, [&] {
    Rows r;
    const VoxelSet slab = surface::read_volume_slab(path, k0 - out.halo_planes, k1 + out.halo_planes, o.volume);
    const SurfelSet near = on_planes(surface::detail::surfels_in_row_order(slab), near_begin, near_end);
    if (near.size() != near_label.size())
      throw Error("distributed_surface_operator: a slab and its owners disagree on the surfels of a plane (internal error)");
    // Kept surfels grouped by surface (stable: row order within each), with their global rows.
    std::vector<std::size_t> start(surfaces + 1, 0);
    for (int label : near_label)
      if (label >= 0) ++start[static_cast<std::size_t>(label) + 1];
    std::partial_sum(start.begin(), start.end(), start.begin());
    r.local.h = h;
    r.local.surfels.resize(start.back());
    r.global.resize(start.back());
    std::vector<std::size_t> fill(start.begin(), start.end() - 1);
    std::vector<std::int64_t> seen(static_cast<std::size_t>(nz), 0);
    for (std::size_t q = 0; q < near.size(); ++q) {
      if (near_label[q] < 0) continue;
      const std::size_t at = fill[static_cast<std::size_t>(near_label[q])]++;
      r.local.surfels[at] = near.surfels[q];
      r.global[at] = static_cast<PetscInt>(kept_first[plane_index(near.surfels[q])] + seen[plane_index(near.surfels[q])]++);
    }
    std::vector<int>& part_surface = r.part_surface;
    r.local.surface_offset.push_back(0);
    for (std::size_t c = 0; c < surfaces; ++c)
      if (start[c + 1] > start[c]) r.local.surface_offset.push_back(start[c + 1]), part_surface.push_back(static_cast<int>(c));
    surface::SurfelNormals normals;
    normals.normals = surface::detail::ii_normals_at(slab, r.local, rho);
    normals.length_scale = l, normals.radius = out.normal_radius;
    if (o.length_scale == 0)
      for (int c : part_surface) normals.surface_length_scales.push_back(surface_l[static_cast<std::size_t>(c)]);
    HeatLaplacianOptions with_stiffness = o.op;
    with_stiffness.stiffness = true;  // A is what the eigen-solver needs
    // Only this rank's rows: the halo's surfels are columns here and rows on their owners.
    std::vector<char> owned(r.global.size());
    for (std::size_t i = 0; i < owned.size(); ++i) owned[i] = r.global[i] >= out.row_begin && r.global[i] < out.row_end;
    r.op = surface::detail::heat_laplacian_rows(r.local, surface::measures(r.local, normals), with_stiffness, owned);
    r.normals = std::move(normals.normals);
    return r;
  });
  out.planes_read = std::min(nz, k1 + out.halo_planes) - std::max<std::int64_t>(0, k0 - out.halo_planes);
  stages.done("rows assembled (halo " + std::to_string(out.halo_planes) + " planes, " + std::to_string(rows.local.size()) +
              " surfels held on rank 0)");

  // 5. Into PETSc, with exact preallocation: each owned row's columns split into the diagonal
  // block (this rank's rows) and the rest.
  const auto n_local = static_cast<PetscInt>(out.row_end - out.row_begin);
  std::vector<PetscInt> d_nnz(static_cast<std::size_t>(n_local), 0), o_nnz(static_cast<std::size_t>(n_local), 0);
  std::vector<Eigen::Index> owned_rows;  // local rows this rank owns
  for (Eigen::Index i = 0; i < static_cast<Eigen::Index>(rows.local.size()); ++i) {
    const PetscInt g = rows.global[static_cast<std::size_t>(i)];
    if (g < out.row_begin || g >= out.row_end) continue;
    owned_rows.push_back(i);
    for (SparseMatrix::InnerIterator it(rows.op.L, i); it; ++it) {
      const PetscInt col = rows.global[static_cast<std::size_t>(it.col())];
      ++(col >= out.row_begin && col < out.row_end ? d_nnz : o_nnz)[static_cast<std::size_t>(g - out.row_begin)];
    }
  }
  if (static_cast<PetscInt>(owned_rows.size()) != n_local)
    throw Error("distributed_surface_operator: a rank holds " + std::to_string(owned_rows.size()) + " of its " + std::to_string(n_local) +
                " rows (internal error)");
  auto assemble = [&](const SparseMatrix& m, Mat* into) {
    petsc_check(MatCreate(comm, into), "MatCreate");
    petsc_check(MatSetSizes(*into, n_local, n_local, static_cast<PetscInt>(out.size), static_cast<PetscInt>(out.size)), "MatSetSizes");
    petsc_check(MatSetType(*into, MATMPIAIJ), "MatSetType");
    petsc_check(MatMPIAIJSetPreallocation(*into, 0, d_nnz.data(), 0, o_nnz.data()), "MatMPIAIJSetPreallocation");
    petsc_check(MatSetOption(*into, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE), "MatSetOption");
    std::vector<PetscInt> cols;
    std::vector<PetscScalar> values;
    for (Eigen::Index i : owned_rows) {
      cols.clear(), values.clear();
      for (SparseMatrix::InnerIterator it(m, i); it; ++it)
        cols.push_back(rows.global[static_cast<std::size_t>(it.col())]), values.push_back(it.value());
      const PetscInt g = rows.global[static_cast<std::size_t>(i)];
      petsc_check(MatSetValues(*into, 1, &g, static_cast<PetscInt>(cols.size()), cols.data(), values.data(), INSERT_VALUES), "MatSetValues");
    }
    petsc_check(MatAssemblyBegin(*into, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
    petsc_check(MatAssemblyEnd(*into, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
  };
  // Each local matrix freed once copied: the peak holds three operators' worth, not four.
  assemble(rows.op.L, &out.L);
  rows.op.L = SparseMatrix();
  assemble(rows.op.A, &out.A);
  rows.op.A = SparseMatrix();
  petsc_check(MatSetOption(out.A, MAT_SYMMETRIC, PETSC_TRUE), "MatSetOption");
  petsc_check(VecCreateMPI(comm, n_local, static_cast<PetscInt>(out.size), &out.mass), "VecCreateMPI");
  // This rank's surfels in row order, with their surface, area and normal.
  std::sort(owned_rows.begin(), owned_rows.end(), [&](Eigen::Index a, Eigen::Index b) {
    return rows.global[static_cast<std::size_t>(a)] < rows.global[static_cast<std::size_t>(b)];
  });
  out.mu.resize(n_local);
  out.normals.resize(n_local, 3);
  std::vector<int> part_of(rows.local.size());
  const std::vector<std::size_t> offsets = rows.local.offsets();
  for (std::size_t p = 0; p + 1 < offsets.size(); ++p)
    for (std::size_t s = offsets[p]; s < offsets[p + 1]; ++s) part_of[s] = static_cast<int>(p);
  std::int64_t clamped = 0;
  for (PetscInt q = 0; q < n_local; ++q) {
    const Eigen::Index i = owned_rows[static_cast<std::size_t>(q)];
    out.surfels.push_back(rows.local.surfels[static_cast<std::size_t>(i)]);
    out.surface_of.push_back(rows.part_surface[static_cast<std::size_t>(part_of[static_cast<std::size_t>(i)])]);
    out.mu[q] = rows.op.mass[i];
    out.normals.row(q) = rows.normals.row(i);
    clamped += out.mu[q] == 0;
    const PetscInt g = out.row_begin + q;
    petsc_check(VecSetValue(out.mass, g, out.mu[q], INSERT_VALUES), "VecSetValue");
  }
  petsc_check(VecAssemblyBegin(out.mass), "VecAssemblyBegin");
  petsc_check(VecAssemblyEnd(out.mass), "VecAssemblyEnd");
  out.clamped = all_reduce(ranks, clamped, MPI_SUM);
  stages.done("PETSc matrices assembled");
  return out;
}

}  // namespace digilap::mpi
