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

}  // namespace digilap
