/// @file CellKeys.h
/// @brief The Morton key of every point's cell on a lattice (origin, inverse cell
///        edge): key[i] = mortonEncode(c) with c[a] = clampToLattice(latticeFloor(
///        (double(p[a]) - origin[a]) * inverseCell)), the key a grid search sorts
///        its points by (Lattice.h, MortonCode.h).
///
/// Two implementations with the same keys bit for bit: the scalar one, and eight
/// points per step with AVX-512 (the same double operations; floor of the clamped
/// value equals the clamped floor, and a NaN coordinate goes to cell 0 as
/// latticeFloor's -1 does). Integer results only, so every processor sorts the
/// points the same way whichever path it takes.
#pragma once

#include "libsph/Types.h"
#include "libsph/search/Lattice.h"
#include "libsph/search/MortonCode.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cstdint>
#include <cstdlib>

#if (defined(__x86_64__) || defined(__i386__)) && !defined(CASCADE_DOUBLE) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define CASCADE_CELL_KEYS_AVX512 1
#endif

namespace cascade::search {

/// Keys of points [begin, end), scalar.
inline void cellKeysScalar(const Vec3r* points, std::size_t begin, std::size_t end, const double origin[3],
                           double inverseCell, std::uint64_t* keys) {
  for (std::size_t i = begin; i < end; ++i) {
    std::uint32_t c[3];
    for (int a = 0; a < 3; ++a) c[a] = clampToLattice(latticeFloor((double(points[i][a]) - origin[a]) * inverseCell));
    keys[i] = mortonEncode(c[0], c[1], c[2]);
  }
}

#ifdef CASCADE_CELL_KEYS_AVX512
/// Whether this processor runs cellKeysAvx512 (AVX-512 F and DQ; CASCADE_NO_AVX512 set: never).
inline bool cellKeysUseAvx512() {
  static const bool avx512 = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
                             std::getenv("CASCADE_NO_AVX512") == nullptr;
  return avx512;
}

/// mortonSpreadBits of eight coordinates (each at most kMortonMaxCoord). (Zero-masked
/// forms here and below: GCC 12's unmasked ones warn of an uninitialised
/// pass-through operand.)
__attribute__((target("avx512f,avx512dq"))) inline __m512i mortonSpreadAvx512(__m512i x) {
  x = _mm512_and_si512(_mm512_or_si512(x, _mm512_maskz_slli_epi64(0xff, x, 32)), _mm512_set1_epi64(0x1f00000000ffffLL));
  x = _mm512_and_si512(_mm512_or_si512(x, _mm512_maskz_slli_epi64(0xff, x, 16)), _mm512_set1_epi64(0x1f0000ff0000ffLL));
  x = _mm512_and_si512(_mm512_or_si512(x, _mm512_maskz_slli_epi64(0xff, x, 8)), _mm512_set1_epi64(0x100f00f00f00f00fLL));
  x = _mm512_and_si512(_mm512_or_si512(x, _mm512_maskz_slli_epi64(0xff, x, 4)), _mm512_set1_epi64(0x10c30c30c30c30c3LL));
  x = _mm512_and_si512(_mm512_or_si512(x, _mm512_maskz_slli_epi64(0xff, x, 2)), _mm512_set1_epi64(0x1249249249249249LL));
  return x;
}

/// cellKeysScalar, eight points a step (the rest scalar).
__attribute__((target("avx512f,avx512dq"))) inline void cellKeysAvx512(const Vec3r* points, std::size_t begin,
                                                                     std::size_t end, const double origin[3],
                                                                     double inverseCell, std::uint64_t* keys) {
  static_assert(sizeof(Vec3r) == 3 * sizeof(float), "points are packed float triples");
  const float* f = points[0].data();
  const __m512d inv = _mm512_set1_pd(inverseCell), zero = _mm512_setzero_pd();
  const __m512d top = _mm512_set1_pd(double(kMortonMaxCoord));
  const __m512d o[3] = {_mm512_set1_pd(origin[0]), _mm512_set1_pd(origin[1]), _mm512_set1_pd(origin[2])};
  // Lanes 0-7 pick coordinate a of the eight points from 24 floats (16 in the
  // first register, 8 in the second: indices 16-23).
  const __m512i pick[3] = {_mm512_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21, 0, 0, 0, 0, 0, 0, 0, 0),
                           _mm512_setr_epi32(1, 4, 7, 10, 13, 16, 19, 22, 0, 0, 0, 0, 0, 0, 0, 0),
                           _mm512_setr_epi32(2, 5, 8, 11, 14, 17, 20, 23, 0, 0, 0, 0, 0, 0, 0, 0)};
  std::size_t i = begin;
  for (; i + 8 <= end; i += 8) {
    const __m512 first = _mm512_loadu_ps(f + 3 * i);
    const __m512 second = _mm512_castps256_ps512(_mm256_loadu_ps(f + 3 * i + 16));
    __m512i key = _mm512_setzero_si512();
    for (int a = 0; a < 3; ++a) {
      const __m256 coordinate =
          _mm512_maskz_extractf32x8_ps(0xff, _mm512_permutex2var_ps(first, pick[a], second), 0);
      const __m512d t = _mm512_mul_pd(_mm512_sub_pd(_mm512_maskz_cvtps_pd(0xff, coordinate), o[a]), inv);
      // max(t, 0) gives 0 for NaN t (the second operand); then min, floor.
      const __m512d clamped = _mm512_maskz_min_pd(0xff, _mm512_maskz_max_pd(0xff, t, zero), top);
      const __m512d cell = _mm512_maskz_roundscale_pd(0xff, clamped, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
      key = _mm512_or_si512(key, _mm512_maskz_sllv_epi64(0xff, mortonSpreadAvx512(_mm512_maskz_cvttpd_epu64(0xff, cell)),
                                                             _mm512_set1_epi64(a)));
    }
    _mm512_storeu_si512(keys + i, key);
  }
  cellKeysScalar(points, i, end, origin, inverseCell, keys);
}
#else
inline bool cellKeysUseAvx512() { return false; }
#endif

/// keys[i] for every point i < count, in parallel.
inline void cellKeys(const Vec3r* points, std::size_t count, const double origin[3], double inverseCell,
                     std::uint64_t* keys) {
  const bool avx512 = cellKeysUseAvx512();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 8192), [&](const auto& range) {
#ifdef CASCADE_CELL_KEYS_AVX512
    if (avx512) {
      cellKeysAvx512(points, range.begin(), range.end(), origin, inverseCell, keys);
      return;
    }
#endif
    (void)avx512;
    cellKeysScalar(points, range.begin(), range.end(), origin, inverseCell, keys);
  });
}

} // namespace cascade::search
