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

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
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
constexpr std::size_t kScanOverwrite = 16;

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
  /// Appends to (bx, by, bz, bi) the position and order[place] of every place in
  /// [begin, end) whose squared distance to the box [lo, hi], computed per axis
  /// as max(lo - p, p - hi, 0), is at most reach2 (NaN positions may be kept);
  /// returns the new count. The buffers must have room for `count + end - begin +
  /// kScanOverwrite` entries.
  static inline std::uint32_t gatherNear(const Real* xs, const Real* ys, const Real* zs,
                                         const std::uint32_t* order, std::uint32_t begin, std::uint32_t end,
                                         const Real lo[3], const Real hi[3], Real reach2, Real* bx, Real* by,
                                         Real* bz, std::uint32_t* bi, std::uint32_t count) {
    for (std::uint32_t j = begin; j < end; ++j) {
      const Real dx = std::max(std::max(lo[0] - xs[j], xs[j] - hi[0]), Real(0));
      const Real dy = std::max(std::max(lo[1] - ys[j], ys[j] - hi[1]), Real(0));
      const Real dz = std::max(std::max(lo[2] - zs[j], zs[j] - hi[2]), Real(0));
      bx[count] = xs[j];
      by[count] = ys[j];
      bz[count] = zs[j];
      bi[count] = order[j];
      count += unsigned(!((dx * dx + dy * dy) + dz * dz > reach2));
    }
    return count;
  }

  /// Moves n entries from src down to dst (dst < src; the ranges may overlap): how
  /// a pair scan's second list joins the first. May write up to kScanOverwrite
  /// entries past dst + n, and read as many past src + n.
  static inline void moveDown(std::uint32_t* dst, const std::uint32_t* src, std::uint32_t n) {
    std::memmove(dst, src, n * sizeof(std::uint32_t));
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

  /// ScanBaseline::moveDown() inline, eight entries a step (each step loads
  /// before it stores, and dst < src, so no entry is overwritten before it is read).
  __attribute__((target("avx2"))) static inline void moveDown(std::uint32_t* dst, const std::uint32_t* src,
                                                              std::uint32_t n) {
    for (std::uint32_t k = 0; k < n; k += 8)
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(dst + k),
                          _mm256_loadu_si256(reinterpret_cast<const __m256i*>(src + k)));
  }

  /// ScanBaseline::gatherNear(), eight places per step.
  __attribute__((target("avx2,popcnt"))) static inline std::uint32_t gatherNear(
      const Real* xs, const Real* ys, const Real* zs, const std::uint32_t* order, std::uint32_t begin,
      std::uint32_t end, const Real lo[3], const Real hi[3], Real reach2, Real* bx, Real* by, Real* bz,
      std::uint32_t* bi, std::uint32_t count) {
    const auto& table = compressTable().lanes;
    const __m256 lx = _mm256_set1_ps(lo[0]), ly = _mm256_set1_ps(lo[1]), lz = _mm256_set1_ps(lo[2]);
    const __m256 hx = _mm256_set1_ps(hi[0]), hy = _mm256_set1_ps(hi[1]), hz = _mm256_set1_ps(hi[2]);
    const __m256 vr2 = _mm256_set1_ps(reach2), zero = _mm256_setzero_ps();
    for (std::uint32_t j = begin; j < end; j += 8) {
      const __m256 x = _mm256_loadu_ps(xs + j), y = _mm256_loadu_ps(ys + j), z = _mm256_loadu_ps(zs + j);
      const __m256 dx = _mm256_max_ps(_mm256_max_ps(_mm256_sub_ps(lx, x), _mm256_sub_ps(x, hx)), zero);
      const __m256 dy = _mm256_max_ps(_mm256_max_ps(_mm256_sub_ps(ly, y), _mm256_sub_ps(y, hy)), zero);
      const __m256 dz = _mm256_max_ps(_mm256_max_ps(_mm256_sub_ps(lz, z), _mm256_sub_ps(z, hz)), zero);
      const __m256 d2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)),
                                      _mm256_mul_ps(dz, dz));
      unsigned mask = static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(d2, vr2, _CMP_LE_OQ)));
      if (end - j < 8) mask &= (1u << (end - j)) - 1u;
      const __m256i lanes = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(table[mask]));
      _mm256_storeu_ps(bx + count, _mm256_permutevar8x32_ps(x, lanes));
      _mm256_storeu_ps(by + count, _mm256_permutevar8x32_ps(y, lanes));
      _mm256_storeu_ps(bz + count, _mm256_permutevar8x32_ps(z, lanes));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(bi + count),
                          _mm256_permutevar8x32_epi32(
                              _mm256_loadu_si256(reinterpret_cast<const __m256i*>(order + j)), lanes));
      count += static_cast<std::uint32_t>(__builtin_popcount(mask));
    }
    return count;
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

/// ScanAvx2's work sixteen points per step (AVX-512F): the comparison gives a
/// lane mask directly, and the neighbours' indices are packed in a register
/// (vpcompressd) and stored at once (16 entries: kScanOverwrite).
struct ScanAvx512 {
  /// vmaxps through its zero-masked form (GCC 12's plain _mm512_max_ps warns of
  /// an uninitialised pass-through operand).
  __attribute__((target("avx512f"), always_inline)) static inline __m512 max16(__m512 a, __m512 b) {
    return _mm512_maskz_max_ps(__mmask16(0xffff), a, b);
  }

  __attribute__((target("avx512f,popcnt"))) static inline std::uint32_t scan(
      const Real* xs, const Real* ys, const Real* zs, const std::uint32_t* order,
      std::uint32_t begin, std::uint32_t end, Real qx, Real qy, Real qz, Real radius2,
      std::uint32_t exclude, std::uint32_t* out) {
    const __m512 vx = _mm512_set1_ps(qx), vy = _mm512_set1_ps(qy), vz = _mm512_set1_ps(qz);
    const __m512 vr2 = _mm512_set1_ps(radius2);
    const __m512i vexclude = _mm512_set1_epi32(static_cast<int>(exclude));
    std::uint32_t n = 0;
    for (std::uint32_t j = begin; j < end; j += 16) {
      const __m512 dx = _mm512_sub_ps(vx, _mm512_loadu_ps(xs + j));
      const __m512 dy = _mm512_sub_ps(vy, _mm512_loadu_ps(ys + j));
      const __m512 dz = _mm512_sub_ps(vz, _mm512_loadu_ps(zs + j));
      const __m512 d2 = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_mul_ps(dy, dy)),
                                      _mm512_mul_ps(dz, dz));
      const __m512i index = _mm512_loadu_si512(order + j);
      const __mmask16 tail = end - j < 16 ? __mmask16((1u << (end - j)) - 1u) : __mmask16(0xffff);
      const __mmask16 mask = _mm512_mask_cmpneq_epi32_mask(
          _mm512_mask_cmp_ps_mask(tail, d2, vr2, _CMP_LE_OQ), index, vexclude);
      _mm512_storeu_si512(out + n, _mm512_maskz_compress_epi32(mask, index));
      n += static_cast<std::uint32_t>(__builtin_popcount(unsigned(mask)));
    }
    return n;
  }

  /// ScanAvx2::moveDown(), sixteen entries a step.
  __attribute__((target("avx512f"))) static inline void moveDown(std::uint32_t* dst, const std::uint32_t* src,
                                                                 std::uint32_t n) {
    for (std::uint32_t k = 0; k < n; k += 16) _mm512_storeu_si512(dst + k, _mm512_loadu_si512(src + k));
  }

  /// ScanBaseline::gatherNear(), sixteen places per step.
  __attribute__((target("avx512f,popcnt"))) static inline std::uint32_t gatherNear(
      const Real* xs, const Real* ys, const Real* zs, const std::uint32_t* order, std::uint32_t begin,
      std::uint32_t end, const Real lo[3], const Real hi[3], Real reach2, Real* bx, Real* by, Real* bz,
      std::uint32_t* bi, std::uint32_t count) {
    const __m512 lx = _mm512_set1_ps(lo[0]), ly = _mm512_set1_ps(lo[1]), lz = _mm512_set1_ps(lo[2]);
    const __m512 hx = _mm512_set1_ps(hi[0]), hy = _mm512_set1_ps(hi[1]), hz = _mm512_set1_ps(hi[2]);
    const __m512 vr2 = _mm512_set1_ps(reach2), zero = _mm512_setzero_ps();
    for (std::uint32_t j = begin; j < end; j += 16) {
      const __m512 x = _mm512_loadu_ps(xs + j), y = _mm512_loadu_ps(ys + j), z = _mm512_loadu_ps(zs + j);
      const __m512 dx = max16(max16(_mm512_sub_ps(lx, x), _mm512_sub_ps(x, hx)), zero);
      const __m512 dy = max16(max16(_mm512_sub_ps(ly, y), _mm512_sub_ps(y, hy)), zero);
      const __m512 dz = max16(max16(_mm512_sub_ps(lz, z), _mm512_sub_ps(z, hz)), zero);
      const __m512 d2 = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_mul_ps(dy, dy)),
                                      _mm512_mul_ps(dz, dz));
      const __mmask16 tail = end - j < 16 ? __mmask16((1u << (end - j)) - 1u) : __mmask16(0xffff);
      const __mmask16 mask = _mm512_mask_cmp_ps_mask(tail, d2, vr2, _CMP_LE_OQ);
      _mm512_storeu_ps(bx + count, _mm512_maskz_compress_ps(mask, x));
      _mm512_storeu_ps(by + count, _mm512_maskz_compress_ps(mask, y));
      _mm512_storeu_ps(bz + count, _mm512_maskz_compress_ps(mask, z));
      _mm512_storeu_si512(bi + count, _mm512_maskz_compress_epi32(mask, _mm512_loadu_si512(order + j)));
      count += static_cast<std::uint32_t>(__builtin_popcount(unsigned(mask)));
    }
    return count;
  }

  /// scan() for two queries over the same places (the points loaded once): adds to nA and nB.
  __attribute__((target("avx512f,popcnt"))) static inline void scanPair(
      const Real* xs, const Real* ys, const Real* zs, const std::uint32_t* order, std::uint32_t begin,
      std::uint32_t end, const Real a[3], const Real b[3], Real radius2, std::uint32_t excludeA,
      std::uint32_t excludeB, std::uint32_t* outA, std::uint32_t* outB, std::uint32_t& nA, std::uint32_t& nB) {
    const __m512 ax = _mm512_set1_ps(a[0]), ay = _mm512_set1_ps(a[1]), az = _mm512_set1_ps(a[2]);
    const __m512 bx = _mm512_set1_ps(b[0]), by = _mm512_set1_ps(b[1]), bz = _mm512_set1_ps(b[2]);
    const __m512 vr2 = _mm512_set1_ps(radius2);
    const __m512i vexcludeA = _mm512_set1_epi32(static_cast<int>(excludeA));
    const __m512i vexcludeB = _mm512_set1_epi32(static_cast<int>(excludeB));
    std::uint32_t na = nA, nb = nB;
    for (std::uint32_t j = begin; j < end; j += 16) {
      const __m512 x = _mm512_loadu_ps(xs + j), y = _mm512_loadu_ps(ys + j), z = _mm512_loadu_ps(zs + j);
      const __m512i index = _mm512_loadu_si512(order + j);
      const __mmask16 tail = end - j < 16 ? __mmask16((1u << (end - j)) - 1u) : __mmask16(0xffff);
      const __m512 dxa = _mm512_sub_ps(ax, x), dya = _mm512_sub_ps(ay, y), dza = _mm512_sub_ps(az, z);
      const __m512 d2a = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(dxa, dxa), _mm512_mul_ps(dya, dya)),
                                       _mm512_mul_ps(dza, dza));
      const __m512 dxb = _mm512_sub_ps(bx, x), dyb = _mm512_sub_ps(by, y), dzb = _mm512_sub_ps(bz, z);
      const __m512 d2b = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(dxb, dxb), _mm512_mul_ps(dyb, dyb)),
                                       _mm512_mul_ps(dzb, dzb));
      const __mmask16 maskA =
          _mm512_mask_cmpneq_epi32_mask(_mm512_mask_cmp_ps_mask(tail, d2a, vr2, _CMP_LE_OQ), index, vexcludeA);
      const __mmask16 maskB =
          _mm512_mask_cmpneq_epi32_mask(_mm512_mask_cmp_ps_mask(tail, d2b, vr2, _CMP_LE_OQ), index, vexcludeB);
      _mm512_storeu_si512(outA + na, _mm512_maskz_compress_epi32(maskA, index));
      _mm512_storeu_si512(outB + nb, _mm512_maskz_compress_epi32(maskB, index));
      na += static_cast<std::uint32_t>(__builtin_popcount(unsigned(maskA)));
      nb += static_cast<std::uint32_t>(__builtin_popcount(unsigned(maskB)));
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
/// Whether this processor runs the AVX-512 scan (CASCADE_NO_AVX512 set: never).
inline bool searchUsesAvx512() {
  static const bool avx512 = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("popcnt") &&
                             std::getenv("CASCADE_NO_AVX512") == nullptr;
  return avx512;
}
#define CASCADE_SEARCH_AVX512_TARGET __attribute__((target("avx512f,avx2,popcnt"), flatten))

#else
using ScanAvx2 = ScanBaseline;
using ScanAvx512 = ScanBaseline;
inline bool searchUsesAvx2() { return false; }
inline bool searchUsesAvx512() { return false; }
#define CASCADE_SEARCH_AVX2_TARGET
#define CASCADE_SEARCH_AVX512_TARGET
#endif

} // namespace cascade::search
