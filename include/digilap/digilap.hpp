// digilap — everything of the curves (2D) at once, with the core they use: shape -> digitization
// -> contours -> normals -> measures -> heat Laplacian -> spectra, heat flow, smoothing, files.
// Include the stage headers instead to keep builds lean; surfaces (3D) are in digilap/surface/.
#pragma once

#include "digilap/core/constants.hpp"
#include "digilap/core/error.hpp"
#include "digilap/core/heat_flow.hpp"
#include "digilap/core/heat_kernel.hpp"
#include "digilap/core/io.hpp"
#include "digilap/core/length_scale.hpp"
#include "digilap/core/operator.hpp"
#include "digilap/core/runs.hpp"
#include "digilap/core/smoothing.hpp"
#include "digilap/core/spectrum.hpp"
#include "digilap/curve/contour.hpp"
#include "digilap/curve/convergence.hpp"
#include "digilap/curve/digitization.hpp"
#include "digilap/curve/ground_truth.hpp"
#include "digilap/curve/heat_laplacian.hpp"
#include "digilap/curve/image.hpp"
#include "digilap/curve/io.hpp"
#include "digilap/curve/length_scale.hpp"
#include "digilap/curve/matrix_free.hpp"
#include "digilap/curve/measures.hpp"
#include "digilap/curve/normals.hpp"
#include "digilap/curve/shapes.hpp"
#include "digilap/curve/smoothing.hpp"
#include "digilap/curve/spectrum.hpp"
