// digilap — the one exception type of the library.
#pragma once

#include <stdexcept>
#include <string>

namespace digilap {

/// Thrown for every invalid input or impossible request. The message says what was wrong and,
/// where it can, what would be right ("h must be > 0 and finite, got -1").
class Error : public std::runtime_error {
public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace digilap
