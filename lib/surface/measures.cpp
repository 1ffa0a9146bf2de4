#include "digilap/surface/measures.hpp"

#include "digilap/core/error.hpp"

#include <algorithm>

namespace digilap::surface {

SurfelMeasures measures(const SurfelSet& surfels, const SurfelNormals& normals) {
  if (normals.normals.rows() != static_cast<Eigen::Index>(surfels.size()))
    throw Error("measures: " + std::to_string(normals.normals.rows()) + " normals for " + std::to_string(surfels.size()) + " surfels");
  SurfelMeasures out;
  out.length_scale = normals.length_scale;
  out.normal_radius = normals.radius;
  out.surface_length_scales = normals.surface_length_scales;
  out.normals = normals.normals;
  out.mu.resize(static_cast<Eigen::Index>(surfels.size()));
  const double h2 = surfels.h * surfels.h;
  for (std::size_t s = 0; s < surfels.size(); ++s) {
    const Surfel& f = surfels.surfels[s];
    const double dot = f.sign * normals.normals(static_cast<Eigen::Index>(s), f.axis);
    if (dot <= 0) ++out.clamped;
    out.mu[static_cast<Eigen::Index>(s)] = h2 * std::max(0.0, dot);
  }
  return out;
}

}  // namespace digilap::surface
