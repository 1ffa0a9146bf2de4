// digilap — everything at once: shape -> digitization -> contours -> normals -> measures ->
// heat Laplacian -> files. Include the stage headers instead to keep builds lean.
#pragma once

#include "digilap/contour.hpp"
#include "digilap/digitization.hpp"
#include "digilap/error.hpp"
#include "digilap/ground_truth.hpp"
#include "digilap/heat_laplacian.hpp"
#include "digilap/io.hpp"
#include "digilap/length_scale.hpp"
#include "digilap/measures.hpp"
#include "digilap/normals.hpp"
#include "digilap/shapes.hpp"
#include "digilap/convergence.hpp"
#include "digilap/spectrum.hpp"
#include "digilap/heat_flow.hpp"
#include "digilap/smoothing.hpp"
#include "digilap/image.hpp"
#include "digilap/matrix_free.hpp"
