// Shared by the command-line apps, one concept per header: options (options.hpp), progress and
// errors on stderr (progress.hpp), the 2D and 3D front ends (curve_front_end.hpp,
// surface_front_end.hpp).
#pragma once

#include "curve_front_end.hpp"
#include "options.hpp"
#include "progress.hpp"
#include "surface_front_end.hpp"
