/// @file Lattice.h
/// @brief The integer lattice both searches key their points on (the 21-bit
///        per axis range of a Morton code): bounds of a point set, and floor
///        and clamp onto the lattice.
#pragma once

#include "libsph/Types.h"
#include "libsph/search/MortonCode.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace cascade::search {

/// Axis-aligned bounds of the finite points added (non-finite points are skipped).
struct PointBounds {
  double lo[3] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                  std::numeric_limits<double>::infinity()};
  double hi[3] = {-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
                  -std::numeric_limits<double>::infinity()};
  void add(const Vec3r& p) {
    if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z())) return;
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], double(p[a]));
      hi[a] = std::max(hi[a], double(p[a]));
    }
  }
  void join(const PointBounds& other) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], other.lo[a]);
      hi[a] = std::max(hi[a], other.hi[a]);
    }
  }
  bool empty() const { return !(lo[0] <= hi[0]); }
};

/// floor(t) limited to [-1, kMortonMaxCoord + 1]; NaN gives -1. Monotone in t.
inline std::int64_t latticeFloor(double t) {
  // floor without a libm call (baseline x86-64 has no roundsd): truncate, then
  // step down for negative fractions; exact for the limited range.
  constexpr std::int64_t kMax = kMortonMaxCoord;
  if (!(t >= -1.0)) return -1;
  if (t > double(kMax + 1)) return kMax + 1;
  const std::int64_t truncated = static_cast<std::int64_t>(t);
  return truncated - (t < double(truncated) ? 1 : 0);
}

/// c clamped onto [0, kMortonMaxCoord].
inline std::uint32_t clampToLattice(std::int64_t c) {
  return static_cast<std::uint32_t>(std::clamp<std::int64_t>(c, 0, std::int64_t(kMortonMaxCoord)));
}

} // namespace cascade::search
