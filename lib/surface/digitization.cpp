#include "digilap/surface/digitization.hpp"

#include "digilap/core/error.hpp"
#include "core/runs.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace digilap::surface {

namespace {
void check_index(const char* what, std::int64_t v) {
  if (v < -kMaxPixelIndex || v > kMaxPixelIndex)
    throw Error(std::string("voxel set: ") + what + " index " + std::to_string(v) + " is outside [-" +
                std::to_string(kMaxPixelIndex) + ", " + std::to_string(kMaxPixelIndex) + "]");
}
// One offset per (y, z) row between the first and the last: estimated before allocating.
void check_rows(std::int64_t nj, std::int64_t nk) {
  const double bytes = 8.0 * static_cast<double>(nj) * static_cast<double>(nk);
  if (bytes > 8e9) {
    std::ostringstream msg;
    msg << "voxel set: " << nj << " x " << nk << " rows would take about " << bytes / 1e9
        << " GB for their offsets alone; use a coarser h";
    throw Error(msg.str());
  }
}
}  // namespace

VoxelSet::VoxelSet(double h) : h_(h) { require_grid_step("voxel set: grid step h", h); }

bool VoxelSet::contains(std::int32_t i, std::int32_t j, std::int32_t k) const {
  return digilap::detail::in_runs(row_runs_begin(j, k), row_runs_end(j, k), i);
}

std::int64_t VoxelSet::voxel_count() const { return digilap::detail::run_total(runs_); }

std::size_t VoxelSet::memory_bytes() const {
  return runs_.capacity() * sizeof(Run) + row_offset_.capacity() * sizeof(std::int64_t);
}

VoxelSet VoxelSet::from_compressed_rows(double h, std::int32_t j0, std::int32_t k0, std::int32_t nj, std::int32_t nk,
                                        std::vector<std::int64_t> row_offset, std::vector<Run> runs) {
  VoxelSet set(h);
  if (nj < 0 || nk < 0 || row_offset.size() != static_cast<std::size_t>(nj) * static_cast<std::size_t>(nk) + 1 ||
      row_offset.front() != 0 || row_offset.back() != static_cast<std::int64_t>(runs.size()))
    throw Error("voxel set: the row offsets must be nj x nk + 1, from 0 to the number of runs");
  if (nj > 0 && nk > 0) {
    check_index("row j", j0), check_index("row j", std::int64_t(j0) + nj - 1);
    check_index("row k", k0), check_index("row k", std::int64_t(k0) + nk - 1);
  }
  for (std::size_t r = 0; r + 1 < row_offset.size(); ++r) {
    if (row_offset[r + 1] < row_offset[r] || row_offset[r + 1] > static_cast<std::int64_t>(runs.size()))
      throw Error("voxel set: the row offsets must not decrease and must end at the number of runs");
    for (std::int64_t q = row_offset[r]; q < row_offset[r + 1]; ++q) {
      const Run& run = runs[static_cast<std::size_t>(q)];
      if (run.end <= run.begin || (q > row_offset[r] && run.begin <= runs[static_cast<std::size_t>(q - 1)].end))
        throw Error("voxel set: the runs of a row must be non-empty, sorted and disjoint");
    }
    if (row_offset[r + 1] > row_offset[r])
      check_index("column i", runs[static_cast<std::size_t>(row_offset[r])].begin),
          check_index("column i", std::int64_t(runs[static_cast<std::size_t>(row_offset[r + 1] - 1)].end) - 1);
  }
  set.j0_ = j0, set.k0_ = k0, set.nj_ = nj, set.nk_ = nk;
  set.row_offset_ = std::move(row_offset);
  set.runs_ = std::move(runs);
  return set;
}

VoxelSet VoxelSet::from_rows(double h, std::int32_t j0, std::int32_t k0, std::int32_t nj, std::int32_t nk,
                             std::vector<std::vector<Run>> rows) {
  if (nj < 0 || nk < 0 || rows.size() != static_cast<std::size_t>(nj) * static_cast<std::size_t>(nk))
    throw Error("voxel set: the rows must be nj x nk");
  std::vector<std::int64_t> row_offset(rows.size() + 1, 0);
  std::vector<Run> runs;
  for (std::size_t r = 0; r < rows.size(); ++r) {
    digilap::detail::normalize_runs(rows[r]);
    runs.insert(runs.end(), rows[r].begin(), rows[r].end());
    row_offset[r + 1] = static_cast<std::int64_t>(runs.size());
    std::vector<Run>().swap(rows[r]);  // release as we go: the peak stays near one copy
  }
  return from_compressed_rows(h, j0, k0, nj, nk, std::move(row_offset), std::move(runs));
}

VoxelSet VoxelSet::from_mask(double h, const std::uint8_t* data, std::int64_t nx, std::int64_t ny, std::int64_t nz,
                             std::ptrdiff_t stride_i, std::ptrdiff_t stride_j, std::ptrdiff_t stride_k) {
  require_grid_step("VoxelSet::from_mask: h", h);
  if (nx < 1 || ny < 1 || nz < 1) throw Error("VoxelSet::from_mask: the mask is empty (" + std::to_string(nx) + " x " +
                                              std::to_string(ny) + " x " + std::to_string(nz) + ")");
  if (std::max({nx, ny, nz}) > kMaxPixelIndex) throw Error("VoxelSet::from_mask: a dimension is above " + std::to_string(kMaxPixelIndex));
  check_rows(ny, nz);
  // Two passes over the mask (count the runs of each row, then write them where they go): the
  // storage is the final one, whatever the shape; one list per row would cost 24+ bytes per
  // row, 2 GB for an 8000 x 8000 x 1 slab (issue 25).
  const std::int64_t rows = ny * nz;
  auto scan = [&](std::int64_t r, auto&& emit) {
    const std::uint8_t* row = data + (r % ny) * stride_j + (r / ny) * stride_k;
    for (std::int64_t i = 0; i < nx;) {
      if (!row[i * stride_i]) { ++i; continue; }
      std::int64_t e = i;
      while (e < nx && row[e * stride_i]) ++e;
      emit(Run{static_cast<std::int32_t>(i), static_cast<std::int32_t>(e)});
      i = e;
    }
  };
  std::vector<std::int64_t> row_offset(static_cast<std::size_t>(rows) + 1, 0);
#pragma omp parallel for schedule(static)
  for (std::int64_t r = 0; r < rows; ++r) scan(r, [&](const Run&) { ++row_offset[static_cast<std::size_t>(r) + 1]; });
  for (std::size_t r = 0; r < static_cast<std::size_t>(rows); ++r) row_offset[r + 1] += row_offset[r];
  std::vector<Run> runs(static_cast<std::size_t>(row_offset.back()));
#pragma omp parallel for schedule(static)
  for (std::int64_t r = 0; r < rows; ++r) {
    std::int64_t at = row_offset[static_cast<std::size_t>(r)];
    scan(r, [&](const Run& run) { runs[static_cast<std::size_t>(at++)] = run; });
  }
  return from_compressed_rows(h, 0, 0, static_cast<std::int32_t>(ny), static_cast<std::int32_t>(nz), std::move(row_offset), std::move(runs));
}

VoxelSet VoxelSet::from_voxels(double h, const std::vector<Eigen::Vector3i>& voxels) {
  if (voxels.empty()) return VoxelSet(h);
  Eigen::Vector3i lo = voxels[0], hi = voxels[0];
  for (const auto& v : voxels) {
    for (int a = 0; a < 3; ++a) check_index("voxel", v[a]);
    lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  }
  const std::int64_t nj = std::int64_t(hi.y()) - lo.y() + 1, nk = std::int64_t(hi.z()) - lo.z() + 1;
  check_rows(nj, nk);
  std::vector<std::vector<Run>> rows(static_cast<std::size_t>(nj * nk));
  for (const auto& v : voxels) rows[static_cast<std::size_t>((v.z() - lo.z()) * nj + (v.y() - lo.y()))].push_back({v.x(), v.x() + 1});
  return from_rows(h, lo.y(), lo.z(), static_cast<std::int32_t>(nj), static_cast<std::int32_t>(nk), std::move(rows));
}

VoxelSet digitize(const Surface& surface, double h) {
  require_grid_step("digitize: grid step h", h);
  const Eigen::AlignedBox3d box = surface.bounding_box();
  const double extent = std::max(box.min().cwiseAbs().maxCoeff(), box.max().cwiseAbs().maxCoeff());
  if (extent / h > 1e9) {
    std::ostringstream msg;
    msg << "digitize: grid step h = " << h << " is too fine for this surface (voxel indices would exceed 1e9)";
    throw Error(msg.str());
  }
  const auto j0 = static_cast<std::int64_t>(std::floor(box.min().y() / h)) - 1, j1 = static_cast<std::int64_t>(std::ceil(box.max().y() / h)) + 1;
  const auto k0 = static_cast<std::int64_t>(std::floor(box.min().z() / h)) - 1, k1 = static_cast<std::int64_t>(std::ceil(box.max().z() / h)) + 1;
  const std::int64_t nj = j1 - j0 + 1, nk = k1 - k0 + 1;
  check_rows(nj, nk);
  std::vector<std::vector<Run>> rows(static_cast<std::size_t>(nj * nk));
  auto in = [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    return surface.inside({static_cast<double>(i) * h, static_cast<double>(j) * h, static_cast<double>(k) * h});
  };
#pragma omp parallel for schedule(dynamic, 16)
  for (std::int64_t r = 0; r < nj * nk; ++r) {
    const std::int64_t j = j0 + r % nj, k = k0 + r / nj;
    for (const auto& [x0, x1] : surface.x_intervals(static_cast<double>(j) * h, static_cast<double>(k) * h)) {
      auto b = static_cast<std::int64_t>(std::floor(x0 / h)) + 1;
      auto last = static_cast<std::int64_t>(std::ceil(x1 / h)) - 1;
      // The crossing and i h may round differently: one voxel of correction on each side.
      if (b <= last && !in(b, j, k)) ++b;
      else if (in(b - 1, j, k)) --b;
      if (last >= b && !in(last, j, k)) --last;
      else if (in(last + 1, j, k)) ++last;
      if (b <= last) rows[static_cast<std::size_t>(r)].push_back({static_cast<std::int32_t>(b), static_cast<std::int32_t>(last + 1)});
    }
  }
  return VoxelSet::from_rows(h, static_cast<std::int32_t>(j0), static_cast<std::int32_t>(k0), static_cast<std::int32_t>(nj),
                             static_cast<std::int32_t>(nk), std::move(rows));
}

}  // namespace digilap::surface
