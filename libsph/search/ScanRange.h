/// @file ScanRange.h
/// @brief The inner loop every spatial search shares: test a contiguous run of
///        points (positions stored as separate x, y, z arrays, in the search's
///        own order) against one query with squaredDistance()'s exact
///        arithmetic, and append the neighbours' point indices.
///
/// Two implementations with the same result bit for bit (same IEEE single
/// operations in the same order as squaredDistance(), no fused multiply-add):
///  - ScanBaseline: SSE2, four points per step, branch-free append;
///  - ScanAvx2: eight points per step, the neighbours' indices packed with one
///    permute from a 256-entry table and stored at once.
/// A search instantiates its query loop for both and picks one at run time
/// (searchUsesAvx2()), so the library still runs on any x86-64 (or, without
/// SSE, falls back to scalar code).
#pragma once

#include "libsph/NeighborSearch.h"
#include "libsph/search/CompressTable.h"

#include <cstdint>
#include <limits>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#if (defined(__x86_64__) || defined(__i386__)) && defined(__SSE2__) && !defined(CASCADE_DOUBLE) && \
    (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define CASCADE_SCAN_X86 1
#endif

namespace cascade::search {

/// Arrays read by a scan (positions, and the order array) must have this many
/// readable elements past the last point (vector loads read whole groups).
constexpr std::size_t kScanPadding = 16;

/// Gathers points[order[k]] into the coordinate arrays x, y, z (k < count),
/// followed by kScanPadding entries of `padding`: NaN for positions, so that
/// vector loads may read past a range without ever matching.
inline void gatherScanPositions(const Vec3r* points, const std::uint32_t* order, std::size_t count,
                                std::vector<Real>& x, std::vector<Real>& y, std::vector<Real>& z,
                                Real padding = std::numeric_limits<Real>::quiet_NaN()) {
  x.resize(count + kScanPadding);
  y.resize(count + kScanPadding);
  z.resize(count + kScanPadding);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 8192), [&](const auto& range) {
    for (std::size_t k = range.begin(); k != range.end(); ++k) {
      const Vec3r& p = points[order[k]];
      x[k] = p.x();
      y[k] = p.y();
      z[k] = p.z();
    }
  });
  for (std::size_t k = count; k < count + kScanPadding; ++k) x[k] = y[k] = z[k] = padding;
}

/// A scan may write this many entries past the neighbours it reports.
constexpr std::size_t kScanOverwrite = 8;

/// Tests places [begin, end) against query (qx, qy, qz): writes order[place]
/// to out for each point with squaredDistance(q, p) <= radius2, except the
/// point index `exclude`, and returns how many it wrote. out must have room
/// for end - begin + kScanOverwrite entries.
struct ScanBaseline {
  static inline std::uint32_t scan(const Real* xs, const Real* ys, const Real* zs,
                                   const std::uint32_t* order, std::uint32_t begin,
                                   std::uint32_t end, Real qx, Real qy, Real qz, Real radius2,
                                   std::uint32_t exclude, std::uint32_t* out) {
    std::uint32_t n = 0;
#ifdef CASCADE_SCAN_X86
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
      for (unsigned lane = 0; lane < 4; ++lane) {
        const std::uint32_t index = order[j + lane];
        out[n] = index;
        n += ((mask >> lane) & 1u) & unsigned(index != exclude);
      }
    }
#else
    const Vec3r q(qx, qy, qz);
    for (std::uint32_t j = begin; j < end; ++j) {
      const std::uint32_t index = order[j];
      out[n] = index;
      n += unsigned(squaredDistance(q, Vec3r(xs[j], ys[j], zs[j])) <= radius2) &
           unsigned(index != exclude);
    }
#endif
    return n;
  }
  /// scan() for two queries over the same places: adds to nA and nB.
  static inline void scanPair(const Real* xs, const Real* ys, const Real* zs, const std::uint32_t* order,
                              std::uint32_t begin, std::uint32_t end, const Real a[3], const Real b[3],
                              Real radius2, std::uint32_t excludeA, std::uint32_t excludeB, std::uint32_t* outA,
                              std::uint32_t* outB, std::uint32_t& nA, std::uint32_t& nB) {
    nA += scan(xs, ys, zs, order, begin, end, a[0], a[1], a[2], radius2, excludeA, outA + nA);
    nB += scan(xs, ys, zs, order, begin, end, b[0], b[1], b[2], radius2, excludeB, outB + nB);
  }
};

#ifdef CASCADE_SCAN_X86

struct ScanAvx2 {
  __attribute__((target("avx2,popcnt"))) static inline std::uint32_t scan(
      const Real* xs, const Real* ys, const Real* zs, const std::uint32_t* order,
      std::uint32_t begin, std::uint32_t end, Real qx, Real qy, Real qz, Real radius2,
      std::uint32_t exclude, std::uint32_t* out) {
    const auto& table = compressTable().lanes;
    const __m256 vx = _mm256_set1_ps(qx), vy = _mm256_set1_ps(qy), vz = _mm256_set1_ps(qz);
    const __m256 vr2 = _mm256_set1_ps(radius2);
    const __m256i vexclude = _mm256_set1_epi32(static_cast<int>(exclude));
    std::uint32_t n = 0;
    for (std::uint32_t j = begin; j < end; j += 8) {
      const __m256 dx = _mm256_sub_ps(vx, _mm256_loadu_ps(xs + j));
      const __m256 dy = _mm256_sub_ps(vy, _mm256_loadu_ps(ys + j));
      const __m256 dz = _mm256_sub_ps(vz, _mm256_loadu_ps(zs + j));
      const __m256 d2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)),
                                      _mm256_mul_ps(dz, dz));
      const __m256i index = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(order + j));
      unsigned mask = static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(d2, vr2, _CMP_LE_OQ)));
      mask &= ~static_cast<unsigned>(
          _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(index, vexclude))));
      if (end - j < 8) mask &= (1u << (end - j)) - 1u;
      const __m256i lanes = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(table[mask]));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + n),
                          _mm256_permutevar8x32_epi32(index, lanes));
      n += static_cast<std::uint32_t>(__builtin_popcount(mask));
    }
    return n;
  }

  /// scan() for two queries over the same places (the points loaded once): adds to nA and nB.
  __attribute__((target("avx2,popcnt"))) static inline void scanPair(
      const Real* xs, const Real* ys, const Real* zs, const std::uint32_t* order, std::uint32_t begin,
      std::uint32_t end, const Real a[3], const Real b[3], Real radius2, std::uint32_t excludeA,
      std::uint32_t excludeB, std::uint32_t* outA, std::uint32_t* outB, std::uint32_t& nA, std::uint32_t& nB) {
    const auto& table = compressTable().lanes;
    const __m256 ax = _mm256_set1_ps(a[0]), ay = _mm256_set1_ps(a[1]), az = _mm256_set1_ps(a[2]);
    const __m256 bx = _mm256_set1_ps(b[0]), by = _mm256_set1_ps(b[1]), bz = _mm256_set1_ps(b[2]);
    const __m256 vr2 = _mm256_set1_ps(radius2);
    const __m256i vexcludeA = _mm256_set1_epi32(static_cast<int>(excludeA));
    const __m256i vexcludeB = _mm256_set1_epi32(static_cast<int>(excludeB));
    std::uint32_t na = nA, nb = nB;
    for (std::uint32_t j = begin; j < end; j += 8) {
      const __m256 x = _mm256_loadu_ps(xs + j), y = _mm256_loadu_ps(ys + j), z = _mm256_loadu_ps(zs + j);
      const __m256i index = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(order + j));
      const unsigned tail = end - j < 8 ? (1u << (end - j)) - 1u : 0xffu;
      const __m256 dxa = _mm256_sub_ps(ax, x), dya = _mm256_sub_ps(ay, y), dza = _mm256_sub_ps(az, z);
      const __m256 d2a = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dxa, dxa), _mm256_mul_ps(dya, dya)),
                                       _mm256_mul_ps(dza, dza));
      const __m256 dxb = _mm256_sub_ps(bx, x), dyb = _mm256_sub_ps(by, y), dzb = _mm256_sub_ps(bz, z);
      const __m256 d2b = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dxb, dxb), _mm256_mul_ps(dyb, dyb)),
                                       _mm256_mul_ps(dzb, dzb));
      const unsigned maskA =
          static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(d2a, vr2, _CMP_LE_OQ))) &
          ~static_cast<unsigned>(_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(index, vexcludeA)))) &
          tail;
      const unsigned maskB =
          static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(d2b, vr2, _CMP_LE_OQ))) &
          ~static_cast<unsigned>(_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(index, vexcludeB)))) &
          tail;
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(outA + na),
                          _mm256_permutevar8x32_epi32(
                              index, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(table[maskA]))));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(outB + nb),
                          _mm256_permutevar8x32_epi32(
                              index, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(table[maskB]))));
      na += static_cast<std::uint32_t>(__builtin_popcount(maskA));
      nb += static_cast<std::uint32_t>(__builtin_popcount(maskB));
    }
    nA = na;
    nB = nb;
  }
};

/// Whether this processor runs the AVX2 scan.
inline bool searchUsesAvx2() {
  static const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("popcnt");
  return avx2;
}
#define CASCADE_SEARCH_AVX2_TARGET __attribute__((target("avx2,popcnt"), flatten))

#else
using ScanAvx2 = ScanBaseline;
inline bool searchUsesAvx2() { return false; }
#define CASCADE_SEARCH_AVX2_TARGET
#endif

} // namespace cascade::search
