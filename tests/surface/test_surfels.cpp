// surface/surfels.hpp: the surfels of a voxel set against brute force, grouped by connected
// surface (6-connected objects, one surface per cavity), and the surface filters.
#include "digilap/surface/surfels.hpp"
#include "digilap/surface/shapes.hpp"
#include "support.hpp"

#include <gtest/gtest.h>

using namespace digilap;
using namespace digilap::surface;
using namespace digilap::surface::test_support;

// Surfels are exactly the faces between a voxel inside and a 6-neighbour outside: counted by
// brute force over the inside test, and each one checked.
TEST(Surface, SurfelsAreTheFacesBetweenInsideAndOutside) {
  for (const char* name : {"sphere", "ellipsoid", "torus"}) {
    const auto s = posed(make_surface(name));
    const double h = 0.08;
    const VoxelSet v = digitize(*s, h);
    std::int64_t faces = 0;
    auto in = [&](std::int64_t i, std::int64_t j, std::int64_t k) { return s->inside(Eigen::Vector3d(i * h, j * h, k * h)); };
    for_each_lattice_point(*s, h, [&](std::int64_t i, std::int64_t j, std::int64_t k) {
      if (in(i, j, k)) faces += !in(i + 1, j, k) + !in(i - 1, j, k) + !in(i, j + 1, k) + !in(i, j - 1, k) + !in(i, j, k + 1) + !in(i, j, k - 1);
    });
    const SurfelSet f = extract_surfels(v);
    EXPECT_EQ(static_cast<std::int64_t>(f.size()), faces) << name;
    for (const Surfel& surfel : f.surfels) {
      Eigen::Vector3i out = surfel.voxel;
      out[surfel.axis] += surfel.sign;
      ASSERT_TRUE(v.contains(surfel.voxel.x(), surfel.voxel.y(), surfel.voxel.z()));
      ASSERT_FALSE(v.contains(out.x(), out.y(), out.z()));
    }
  }
}

TEST(SurfaceParts, SurfelsAreGroupedBySurface) {
  // Two balls and a hollow ball (outer and cavity surfaces): four surfaces.
  const auto voxels = voxels_of(40, [](int i, int j, int k) {
    return in_ball(i, j, k, 8, 8, 8, 5) || in_ball(i, j, k, 30, 8, 8, 4) ||
           (in_ball(i, j, k, 20, 26, 26, 10) && !in_ball(i, j, k, 20, 26, 26, 5));
  });
  const VoxelSet set = VoxelSet::from_voxels(1.0, voxels);
  const SurfelSet surfels = extract_surfels(set);
  ASSERT_EQ(surfels.surfaces(), 4u);
  const SurfelComponents components = connected_surfaces(set, surfels);
  for (std::size_t c = 0; c < 4; ++c)
    for (std::size_t s = surfels.surface_offset[c]; s < surfels.surface_offset[c + 1]; ++s)
      ASSERT_EQ(components.of_surfel[s], static_cast<int>(c)) << "surfel " << s;
  const FilteredSurfels largest = filter_surfels(set, surfels, {0, true});
  EXPECT_EQ(largest.surfels.surfaces(), 1u);
  EXPECT_EQ(largest.surfels.surface_offset.back(), largest.surfels.size());
}

// Connected surfaces: one per surface of the set; voxels meeting by an edge or a corner only
// are separate objects (6-connected), a hole through an object (the torus) is one surface.
TEST(Surface, ConnectedSurfacesAndFilters) {
  using V = std::vector<Eigen::Vector3i>;
  auto components = [](const V& voxels) {
    const VoxelSet set = VoxelSet::from_voxels(1.0, voxels);
    return connected_surfaces(set, extract_surfels(set)).sizes;
  };
  EXPECT_EQ(components(V{{0, 0, 0}}), (std::vector<std::size_t>{6}));
  EXPECT_EQ(components(V{{0, 0, 0}, {1, 0, 0}}), (std::vector<std::size_t>{10}));       // face-adjacent: one box
  EXPECT_EQ(components(V{{0, 0, 0}, {1, 1, 0}}), (std::vector<std::size_t>{6, 6}));     // by an edge: apart
  EXPECT_EQ(components(V{{0, 0, 0}, {1, 1, 1}}), (std::vector<std::size_t>{6, 6}));     // by a corner: apart
  V shell;  // a hollow 5^3 cube: an outer and an inner surface
  for (int k = 0; k < 5; ++k)
    for (int j = 0; j < 5; ++j)
      for (int i = 0; i < 5; ++i)
        if (i % 4 == 0 || j % 4 == 0 || k % 4 == 0) shell.emplace_back(i, j, k);
  EXPECT_EQ(components(shell), (std::vector<std::size_t>{150, 54}));
  // Two spheres and a speck: filters by size and largest.
  Sphere big, small(0.5);
  big.set_pose(kCentre, Eigen::Matrix3d::Identity());
  small.set_pose(kCentre + Eigen::Vector3d(3, 0, 0), Eigen::Matrix3d::Identity());
  V voxels;
  for (const Surface* s : {static_cast<const Surface*>(&big), static_cast<const Surface*>(&small)}) {
    const VoxelSet v = digitize(*s, 0.1);
    for (std::int32_t k = v.k_begin(); k < v.k_end(); ++k)
      for (std::int32_t j = v.j_begin(); j < v.j_end(); ++j)
        for (const digilap::Run* r = v.row_runs_begin(j, k); r != v.row_runs_end(j, k); ++r)
          for (std::int32_t i = r->begin; i < r->end; ++i) voxels.emplace_back(i, j, k);
  }
  voxels.emplace_back(0, 40, 0);
  const VoxelSet set = VoxelSet::from_voxels(0.1, voxels);
  const SurfelSet all = extract_surfels(set);
  const std::vector<std::size_t> sizes = connected_surfaces(set, all).sizes;
  ASSERT_EQ(sizes.size(), 3u);
  EXPECT_EQ(filter_surfels(set, all, {7, false}).dropped, 1u);  // the speck's 6 surfels
  const FilteredSurfels largest = filter_surfels(set, all, {0, true});
  EXPECT_EQ(largest.dropped, 2u);
  EXPECT_EQ(largest.surfels.size(), extract_surfels(digitize(big, 0.1)).size());
  EXPECT_EQ(connected_surfaces(digitize(*posed(make_surface("torus")), 0.07), extract_surfels(digitize(*posed(make_surface("torus")), 0.07))).sizes.size(), 1u);
}
