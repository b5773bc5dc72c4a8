// Study knobs for validation tests: a number from the environment, or a default.
#pragma once

#include <cstdlib>

namespace cascade::test {

/// The value of environment variable `name` as a number, or `fallback` if it is unset.
inline double envOr(const char* name, double fallback) {
  const char* v = std::getenv(name);
  return v ? std::atof(v) : fallback;
}

} // namespace cascade::test
