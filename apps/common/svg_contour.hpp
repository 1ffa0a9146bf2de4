// Pictures of functions on contours: each panel draws the contours coloured by a function.
#pragma once

#include <Eigen/Core>

#include <string>
#include <vector>

namespace digilap::app {

struct ContourPanel {
  std::string title;
  Eigen::VectorXd values;  // one per element (row)
};

/// Writes a grid of panels (`columns` per row) as one SVG. Colours: a diverging blue-white-red
/// map, white at 0, saturated at +-max|value| over all panels (one shared scale, shown in a
/// colour bar). `row_offset` delimits the contours (as ContourOperator::row_offset).
void save_contour_panels(const std::string& path, const Eigen::MatrixX2d& positions,
                         const std::vector<Eigen::Index>& row_offset, const std::vector<ContourPanel>& panels,
                         int columns, const std::string& title);

}  // namespace digilap::app
