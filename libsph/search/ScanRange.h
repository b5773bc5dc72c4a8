/// @file ScanRange.h
/// @brief The inner loop every spatial search shares: test a contiguous run of
///        points (positions stored as separate x, y, z arrays, in the search's
///        own order) against one query with squaredDistance()'s exact
///        arithmetic, and append the neighbours' point indices. SSE for float
///        (four points per step, same operations and order as the scalar code,
///        so the same bits), scalar otherwise.
#pragma once

#include "libsph/NeighborSearch.h"

#include <cstdint>

#if defined(__SSE2__) && !defined(CASCADE_DOUBLE)
#include <immintrin.h>
#define CASCADE_SCAN_SSE 1
#endif

namespace cascade::search {

/// Arrays read by scanRange() must have this many readable elements past the
/// last point (vector loads read whole groups of four).
constexpr std::size_t kScanPadding = 8;

/// Tests the points at places [begin, end) against query (qx, qy, qz): writes
/// order[place] to out for each with squaredDistance(q, p) <= radius2, except
/// the point index `exclude`, and returns how many it wrote. out must have room
/// for end - begin + 1 entries.
inline std::uint32_t scanRange(const Real* xs, const Real* ys, const Real* zs,
                               const std::uint32_t* order, std::uint32_t begin, std::uint32_t end,
                               Real qx, Real qy, Real qz, Real radius2, std::uint32_t exclude,
                               std::uint32_t* out) {
  std::uint32_t n = 0;
#ifdef CASCADE_SCAN_SSE
  const __m128 vx = _mm_set1_ps(qx), vy = _mm_set1_ps(qy), vz = _mm_set1_ps(qz);
  const __m128 vr2 = _mm_set1_ps(radius2);
  for (std::uint32_t j = begin; j < end; j += 4) {
    const __m128 dx = _mm_sub_ps(vx, _mm_loadu_ps(xs + j));
    const __m128 dy = _mm_sub_ps(vy, _mm_loadu_ps(ys + j));
    const __m128 dz = _mm_sub_ps(vz, _mm_loadu_ps(zs + j));
    // ((dx*dx + dy*dy) + dz*dz), the evaluation order of squaredDistance().
    const __m128 d2 =
        _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz));
    unsigned mask = static_cast<unsigned>(_mm_movemask_ps(_mm_cmple_ps(d2, vr2)));
    if (end - j < 4) mask &= (1u << (end - j)) - 1u;
    while (mask) {
      const unsigned bit = static_cast<unsigned>(__builtin_ctz(mask));
      mask &= mask - 1;
      const std::uint32_t index = order[j + bit];
      out[n] = index;
      n += (index != exclude);
    }
  }
#else
  const Vec3r q(qx, qy, qz);
  for (std::uint32_t j = begin; j < end; ++j) {
    if (squaredDistance(q, Vec3r(xs[j], ys[j], zs[j])) <= radius2) {
      const std::uint32_t index = order[j];
      out[n] = index;
      n += (index != exclude);
    }
  }
#endif
  return n;
}

} // namespace cascade::search
