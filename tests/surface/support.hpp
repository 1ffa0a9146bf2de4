// Shared by the surface tests: the reference surfaces posed off the lattice (SPEC §7), the
// pipeline from a surface or from voxels to the operator, and the x^2 error against SPEC §7.
#pragma once

#include "digilap/core/constants.hpp"
#include "digilap/core/error.hpp"
#include "digilap/core/heat_flow.hpp"
#include "digilap/core/spectrum.hpp"
#include "digilap/surface/ground_truth.hpp"
#include "digilap/surface/heat_laplacian.hpp"
#include "digilap/surface/volume.hpp"

#include <Eigen/Dense>

#include <array>
#include <cstdint>
#include <cmath>
#include <functional>
#include <memory>
#include <vector>

namespace digilap::surface::test_support {

using digilap::kPi;
inline const Eigen::Vector3d kCentre(0.0123, -0.0371, 0.0217);  // off the lattice (SPEC §7)

inline std::unique_ptr<Surface> posed(std::unique_ptr<Surface> s) {
  s->set_pose(kCentre, Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix());
  return s;
}

struct Pipeline {
  VoxelSet voxels;
  SurfelSet surfels;
  SurfelMeasures mu;
  SurfaceOperator op;
};

// The reference computation's parameters: t = c_t h^(2/3) (c_t = 0.03), k = 6, the chord
// kernel, SPEC §7's plain II normals k_R = 1 (l = 1), or the exact normals.
inline Pipeline run(const Surface& s, double h, bool exact = false, double c_t = 0.03) {
  Pipeline p;
  p.voxels = digitize(s, h);
  p.surfels = extract_surfels(p.voxels);
  p.mu = measures(p.surfels, exact ? exact_normals(s, p.surfels, 1.0) : ii_normals(p.voxels, p.surfels, {1.0, 1.0, 0.02, false}));
  HeatLaplacianOptions o;
  o.c_t = c_t;
  o.surface_kernel = SurfaceKernel::Chord;  // SPEC §7's, as the reference implementation
  p.op = heat_laplacian(p.surfels, p.mu, o);
  return p;
}

// From voxels (h = 1) with the defaults: the measured length scale, one part per surface.
inline Pipeline run(const std::vector<Eigen::Vector3i>& voxels, const HeatLaplacianOptions& o = {}) {
  Pipeline p;
  p.voxels = VoxelSet::from_voxels(1.0, voxels);
  p.surfels = extract_surfels(p.voxels);
  p.mu = measures(p.surfels, ii_normals(p.voxels, p.surfels));
  p.op = heat_laplacian(p.surfels, p.mu, o);
  return p;
}

// max |L g - Delta_S g| / max |Delta_S g| for g = x^2 about the surface's centre, at the closest
// points (surface/ground_truth.hpp, SPEC §7).
inline double x2_error(const Surface& s, const SurfaceOperator& op) {
  const SurfaceTestSamples x2 = sample_test_function(s, "x2", op.positions);
  return relative_max_error(op.L * x2.values, x2);
}

// Every lattice point (i, j, k) of step h in the surface's bounding box grown by 2 voxels: the
// brute-force side of the digitization and surfel tests.
template <class Visit>
void for_each_lattice_point(const Surface& s, double h, Visit visit) {
  const auto box = s.bounding_box();
  for (std::int64_t k = std::floor(box.min().z() / h) - 2; k <= std::ceil(box.max().z() / h) + 2; ++k)
    for (std::int64_t j = std::floor(box.min().y() / h) - 2; j <= std::ceil(box.max().y() / h) + 2; ++j)
      for (std::int64_t i = std::floor(box.min().x() / h) - 2; i <= std::ceil(box.max().x() / h) + 2; ++i) visit(i, j, k);
}

using Predicate = std::function<bool(int, int, int)>;

// The voxels of [0, n)^3 for which `inside` holds.
inline std::vector<Eigen::Vector3i> voxels_of(int n, const Predicate& inside) {
  std::vector<Eigen::Vector3i> v;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        if (inside(i, j, k)) v.emplace_back(i, j, k);
  return v;
}

inline bool in_ball(int i, int j, int k, double cx, double cy, double cz, double r) {
  return (i - cx) * (i - cx) + (j - cy) * (j - cy) + (k - cz) * (k - cz) < r * r;
}

// The volume's axes permuted by `axes` and flipped where `flip` says, within [0, n)^3.
inline std::vector<Eigen::Vector3i> transformed(const std::vector<Eigen::Vector3i>& voxels, int n, std::array<int, 3> axes,
                                                std::array<bool, 3> flip) {
  std::vector<Eigen::Vector3i> out;
  for (const Eigen::Vector3i& v : voxels) {
    Eigen::Vector3i w;
    for (int a = 0; a < 3; ++a) w[a] = flip[a] ? n - 1 - v[axes[a]] : v[axes[a]];
    out.push_back(w);
  }
  return out;
}

// Surfels of the surfaces of at least 8 surfels and their measures (the matrix-free tests).
inline Pipeline filtered(const VoxelSet& set) {
  Pipeline p;
  p.voxels = set;
  p.surfels = filter_surfels(set, extract_surfels(set), SurfelFilter{8, false}).surfels;
  p.mu = measures(p.surfels, ii_normals(set, p.surfels));
  return p;
}

// A ball of radius 9 voxels and, 4 voxels away (closer than the cut), a ball of radius 5: two
// surfaces, two heat times.
inline VoxelSet two_balls() {
  std::vector<Eigen::Vector3i> v;
  for (int k = 0; k < 40; ++k)
    for (int j = 0; j < 24; ++j)
      for (int i = 0; i < 24; ++i) {
        const double a = (i - 11.7) * (i - 11.7) + (j - 11.4) * (j - 11.4) + (k - 10.2) * (k - 10.2);
        const double b = (i - 11.2) * (i - 11.2) + (j - 11.9) * (j - 11.9) + (k - 28.6) * (k - 28.6);
        if (a < 81 || b < 25) v.emplace_back(i, j, k);
      }
  return VoxelSet::from_voxels(1.0, v);
}

// A real structure with zero-area surfels: label 5 of the 2 mm JHU atlas (committed in tests/data).
inline VoxelSet real_label() {
  VolumeOptions o;
  o.label = 5;
  return read_volume(DIGILAP_SOURCE_DATA "/JHU-WhiteMatter-labels-2mm.nii.gz", o);
}

// A smooth deterministic block of b columns on n rows.
inline Eigen::MatrixXd block(Eigen::Index n, Eigen::Index b) {
  Eigen::MatrixXd x(n, b);
  for (Eigen::Index k = 0; k < x.size(); ++k) x.data()[k] = std::sin(0.37 * static_cast<double>(k) + 0.1);
  return x;
}

}  // namespace digilap::surface::test_support
