// Pictures of functions on digital surfaces: an orthographic view of the surfels, shaded by
// their estimated normals and coloured by a function, one panel per function.
#pragma once

#include "digilap/surface/surfels.hpp"

#include <Eigen/Core>

#include <string>
#include <vector>

namespace digilap::app {

struct SurfacePanel {
  std::string title;
  Eigen::VectorXd values;  // one per surfel
};

/// Writes a grid of panels as one SVG: the surfels facing the viewer (direction (1, -1.4, 1.1)),
/// far ones first, each a quad coloured blue-white-red by its value (white at 0, saturated at
/// the panel's max |value|) and darkened by the angle of its normal to the light.
void save_surface_panels(const std::string& path, const surface::SurfelSet& surfels, const Eigen::MatrixX3d& normals,
                         const std::vector<SurfacePanel>& panels, int columns, const std::string& title);

}  // namespace digilap::app
