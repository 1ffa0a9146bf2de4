// Kept for one release: this header moved to digilap/curve/normals.hpp (the 2D pipeline; see the
// CHANGELOG's migration note). Its names stay digilap::X through the inline namespace curve.
#pragma once

#include "digilap/curve/normals.hpp"
