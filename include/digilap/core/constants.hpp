// digilap — numerical constants shared by every stage (core: every dimension).
#pragma once

namespace digilap {

/// pi to double precision (std::numbers::pi is C++20; the library is C++17).
inline constexpr double kPi = 3.14159265358979323846;

}  // namespace digilap
