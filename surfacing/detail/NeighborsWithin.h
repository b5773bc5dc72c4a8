/// @file NeighborsWithin.h
/// @brief Of candidate points (float columns x, y, z), those closer than a radius
///        to a point, in candidate order, with their squared distances: the
///        fixed-radius neighbour test of a cell-grid search (Green 2010,
///        "Particle Simulation using CUDA"), compacted without a branch per
///        candidate. An AVX2 version (8 candidates per step, compacted by a
///        permutation table) and a scalar one; both give the same lists and the
///        same bits (|o|^2 = (ox^2 + oy^2) + oz^2 in either, no contraction).
/// Internal to surfacing.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#if defined(__x86_64__) && defined(__GNUC__)
#define CASCADE_NEIGHBORS_WITHIN_AVX2 1
#include <immintrin.h>
#endif

namespace cascade::surfacing::detail {

/// Extra entries past `count` that the AVX2 version may read from x, y, z and
/// `ids` (their values do not matter) and write to `within` and `distance2`.
constexpr std::size_t kNeighborsWithinPadding = 8;

/// Writes the indices c < count with |(x, y, z)[c] - p|^2 < radius2 and
/// ids[c] != self to within[0, found) in ascending order, their squared
/// distances to distance2[0, found); returns found.
inline std::size_t neighborsWithinScalar(const float* x, const float* y, const float* z, const std::uint32_t* ids,
                                         std::size_t count, float px, float py, float pz, float radius2,
                                         std::uint32_t self, std::uint32_t* within, float* distance2) {
  std::size_t found = 0;
  for (std::size_t c = 0; c < count; ++c) {
    const float ox = x[c] - px, oy = y[c] - py, oz = z[c] - pz;
    const float r2 = ox * ox + oy * oy + oz * oz;
    within[found] = std::uint32_t(c);
    distance2[found] = r2;
    found += std::size_t((r2 < radius2) & (ids[c] != self));
  }
  return found;
}

#ifdef CASCADE_NEIGHBORS_WITHIN_AVX2
namespace neighbors_within {
/// For each 8-bit lane mask, the lanes that are set, first (a left-packing permutation).
struct PackTable {
  std::array<std::array<std::uint32_t, 8>, 256> lanes{};
  constexpr PackTable() {
    for (unsigned mask = 0; mask < 256; ++mask) {
      unsigned next = 0;
      for (unsigned lane = 0; lane < 8; ++lane)
        if (mask & (1u << lane)) lanes[mask][next++] = lane;
    }
  }
};
inline constexpr PackTable kPack{};
} // namespace neighbors_within

/// neighborsWithinScalar with 8 candidates per step; x, y, z, ids readable and
/// within, distance2 writable up to kNeighborsWithinPadding past their ends.
__attribute__((target("avx2,popcnt"))) inline std::size_t neighborsWithinAvx2(
    const float* x, const float* y, const float* z, const std::uint32_t* ids, std::size_t count, float px, float py,
    float pz, float radius2, std::uint32_t self, std::uint32_t* within, float* distance2) {
  const __m256 vx = _mm256_set1_ps(px), vy = _mm256_set1_ps(py), vz = _mm256_set1_ps(pz);
  const __m256 vRadius2 = _mm256_set1_ps(radius2);
  const __m256i vSelf = _mm256_set1_epi32(int(self)), iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  std::size_t found = 0;
  for (std::size_t c = 0; c < count; c += 8) {
    const __m256 ox = _mm256_sub_ps(_mm256_loadu_ps(x + c), vx);
    const __m256 oy = _mm256_sub_ps(_mm256_loadu_ps(y + c), vy);
    const __m256 oz = _mm256_sub_ps(_mm256_loadu_ps(z + c), vz);
    const __m256 r2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ox, ox), _mm256_mul_ps(oy, oy)), _mm256_mul_ps(oz, oz));
    const __m256i id = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(ids + c));
    unsigned mask = unsigned(_mm256_movemask_ps(_mm256_cmp_ps(r2, vRadius2, _CMP_LT_OQ))) &
                    ~unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(id, vSelf))));
    if (count - c < 8) mask &= (1u << (count - c)) - 1;  // lanes past the end
    const __m256i pack =
        _mm256_loadu_si256(reinterpret_cast<const __m256i*>(neighbors_within::kPack.lanes[mask].data()));
    const __m256i index = _mm256_add_epi32(_mm256_set1_epi32(int(c)), iota);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(within + found), _mm256_permutevar8x32_epi32(index, pack));
    _mm256_storeu_ps(distance2 + found, _mm256_permutevar8x32_ps(r2, pack));
    found += std::size_t(_mm_popcnt_u32(mask));
  }
  return found;
}
#endif

/// The AVX2 version where the processor has it, else the scalar one.
inline std::size_t neighborsWithin(const float* x, const float* y, const float* z, const std::uint32_t* ids,
                                   std::size_t count, float px, float py, float pz, float radius2, std::uint32_t self,
                                   std::uint32_t* within, float* distance2) {
#ifdef CASCADE_NEIGHBORS_WITHIN_AVX2
  static const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("popcnt");
  if (avx2) return neighborsWithinAvx2(x, y, z, ids, count, px, py, pz, radius2, self, within, distance2);
#endif
  return neighborsWithinScalar(x, y, z, ids, count, px, py, pz, radius2, self, within, distance2);
}

} // namespace cascade::surfacing::detail
