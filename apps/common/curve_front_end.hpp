// The apps' 2D front end: shape or image -> digital set -> contours -> normals -> measures.
#pragma once

#include "options.hpp"
#include "progress.hpp"

#include "digilap/digilap.hpp"

#include <memory>
#include <string>

namespace digilap::app {

struct FrontEnd {
  std::unique_ptr<Shape> shape;  // null for an image
  std::string name;              // the shape's name or the image's file name
  double exact_length = 0.0;     // the curve's length; NaN for an image (no exact curve)
  DigitalSet set;
  ContourSet contours;
  LinelNormals normals;
  Measures measures;
  double seconds_digitize = 0, seconds_contours = 0, seconds_normals = 0, seconds_measures = 0;
};

/// Shape or image -> digital set -> contours -> normals -> measures, timed stage by stage.
FrontEnd run_front_end(const FrontEndOptions& options, Progress& progress);

/// The heat Laplacian of the front end's contours, timed as the stage "operator".
ContourOperator build_operator(const FrontEnd& fe, const HeatLaplacianOptions& options, Progress& progress);

}  // namespace digilap::app
