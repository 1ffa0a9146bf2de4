// Test helper: the message of the digilap::Error that f throws, or "" when it throws none.
#pragma once

#include "digilap/core/error.hpp"

#include <functional>
#include <string>

inline std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const digilap::Error& e) {
    return e.what();
  }
  return "";
}
