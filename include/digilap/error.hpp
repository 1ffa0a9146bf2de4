// digilap — forwarding header (one release): the error type moved to digilap/core/error.hpp.
#pragma once
#include "digilap/core/error.hpp"
