// digilap internal — the pieces of surface::length_scale (length_scale.cpp) that a distributed
// run also needs, so that its l is the one-machine l bit for bit: which surfels are sampled
// (by position, from the global bounding box), the II radius of curvature at a surfel, and one
// round from the samples' radii to l_c and l.
#pragma once

#include "digilap/surface/digitization.hpp"
#include "digilap/surface/surfels.hpp"
#include "ball_moments.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace digilap::surface::detail {

constexpr double kLengthFloorVoxels = 4.0;
constexpr std::size_t kLengthMaxSamples = 20000;
constexpr int kLengthRounds = 3;

/// Whether surfel f is sampled when n surfels have the doubled-centre bounding box [lo, hi]
/// (all of them up to kLengthMaxSamples; else a hash of the position relative to the box's
/// centre, invariant under the lattice's symmetries, is 0 modulo the stride).
bool sampled_for_length(const Surfel& f, std::size_t n, const std::array<std::int64_t, 3>& lo, const std::array<std::int64_t, 3>& hi);
/// The equal-volume radius (voxels) of what a surface encloses, from its twice-enclosed voxels.
double equal_volume_radius(std::int64_t twice_enclosed_voxels);
/// The ball radius (voxels) of a round from the previous l (voxels) and the largest surface's size.
double length_ball_radius(double k_R, double l, double largest);
/// 1 / |H| (voxels) at surfel f from the II mean curvature in the ball (its rows, BallRows).
double ii_radius_of_curvature(const VoxelSet& set, const Surfel& f, const BallRows& ball);
/// One round: sample q has radius[q] and lies on surface surface_of[q]; size[c] and surfels[c]
/// are each surface's size bound (voxels) and surfel count. Writes l_c (voxels, 0 for a surface
/// without samples) into per_surface and returns l (voxels), the weighted median. Independent of
/// the order of the samples.
double length_round(const std::vector<double>& radius, const std::vector<std::size_t>& surface_of, const std::vector<double>& size,
                    const std::vector<std::size_t>& surfels, double quantile, std::vector<double>& per_surface);

}  // namespace digilap::surface::detail
