// Kept for one release: this header moved to digilap/core/heat_flow.hpp (written once for every
// dimension; see the CHANGELOG's migration note). It also brought the contour spectra, as before.
#pragma once

#include "digilap/core/heat_flow.hpp"
#include "digilap/curve/spectrum.hpp"
