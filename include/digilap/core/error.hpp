// digilap — the one exception type of the library (core: every dimension).
#pragma once

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace digilap {

/// Thrown for every invalid input or impossible request. The message says what was wrong and,
/// where it can, what would be right ("h must be > 0 and finite, got -1").
class Error : public std::runtime_error {
public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

/// Throws Error("<what> must be > 0 and finite, got <value>") unless value is > 0 and finite:
/// the one check every step, time, radius and constant of the pipeline goes through.
inline void require_positive(const std::string& what, double value) {
  if (value > 0 && std::isfinite(value)) return;
  std::ostringstream msg;
  msg << what << " must be > 0 and finite, got " << value;
  throw Error(msg.str());
}

/// The grid steps the pipeline represents: areas (h^2 N), heat times (~h^2) and eigenvalues
/// (~1/h^2) of any grid up to 10^9 cells stay finite and normal in double for h in
/// [1e-30, 1e30] (metres to femtometres, in any unit); outside it they overflow to inf or
/// underflow to 0, a silent wrong answer.
inline constexpr double kMinGridStep = 1e-30, kMaxGridStep = 1e30;

/// Throws Error unless h is in [kMinGridStep, kMaxGridStep] (so > 0 and finite), saying why.
inline void require_grid_step(const std::string& what, double h) {
  require_positive(what, h);
  if (h >= kMinGridStep && h <= kMaxGridStep) return;
  std::ostringstream msg;
  msg << what << " = " << h << " is outside [" << kMinGridStep << ", " << kMaxGridStep
      << "], where areas, heat times and eigenvalues overflow or vanish in double; give the step in another unit";
  throw Error(msg.str());
}

}  // namespace digilap
