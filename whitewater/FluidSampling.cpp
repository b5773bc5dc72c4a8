// The fluid around diffuse particles: neighbour counts and v_f, eight places at a time.
#include "whitewater/FluidSampling.h"

#include "libsph/search/ScanRange.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <cstdlib>

namespace cascade::whitewater {

namespace {

using PlaceRange = search::UniformGridSearch::PlaceRange;
constexpr int kLanes = 8;

/// The places of the grid and their velocities (padded arrays).
struct Places {
  const Real *x, *y, *z;
  const Real *vx, *vy, *vz;  ///< null: counts only
};

/// Lane sums added in one fixed order.
inline float addLanes(const float lanes[kLanes]) {
  return ((lanes[0] + lanes[1]) + (lanes[2] + lanes[3])) + ((lanes[4] + lanes[5]) + (lanes[6] + lanes[7]));
}

inline void finish(std::uint32_t neighbors, const float w[kLanes], const float sx[kLanes], const float sy[kLanes],
                   const float sz[kLanes], FluidSample& out) {
  out.neighbors = neighbors;
  out.weight = addLanes(w);
  out.velocity = out.weight > 0 ? Vec3r(Vec3r(addLanes(sx), addLanes(sy), addLanes(sz)) / out.weight)
                                : Vec3r::Zero();
}

/// One position against the places of `ranges`: per lane l, places begin + 8t + l.
template <bool kVelocity>
void sampleBaseline(const Places& places, const PlaceRange* ranges, std::uint32_t rangeCount, const Vec3r& q,
                    Real h2, Real invH, FluidSample& out) {
  float w[kLanes] = {}, sx[kLanes] = {}, sy[kLanes] = {}, sz[kLanes] = {};
  std::uint32_t neighbors = 0;
  for (std::uint32_t r = 0; r < rangeCount; ++r)
    for (std::uint32_t j = ranges[r].begin; j < ranges[r].end; j += kLanes)
      for (int l = 0; l < kLanes; ++l) {
        const std::uint32_t p = j + std::uint32_t(l);
        const Real dx = q.x() - places.x[p], dy = q.y() - places.y[p], dz = q.z() - places.z[p];
        const Real d2 = (dx * dx + dy * dy) + dz * dz;  // squaredDistance()'s order
        const bool in = p < ranges[r].end && d2 <= h2;
        neighbors += in;
        if constexpr (kVelocity) {
          float weight = Real(1) - std::sqrt(d2) * invH;
          weight = weight > 0 ? weight : 0;
          weight = in ? weight : 0;
          w[l] += weight;
          sx[l] += weight * places.vx[p];
          sy[l] += weight * places.vy[p];
          sz[l] += weight * places.vz[p];
        }
      }
  finish(neighbors, w, sx, sy, sz, out);
}

#ifdef CASCADE_SCAN_X86
/// sampleBaseline() with AVX2: the same operations lane by lane.
template <bool kVelocity>
__attribute__((target("avx2,popcnt"))) void sampleAvx2(const Places& places, const PlaceRange* ranges,
                                                         std::uint32_t rangeCount, const Vec3r& q, Real h2,
                                                         Real invH, FluidSample& out) {
  const __m256 qx = _mm256_set1_ps(q.x()), qy = _mm256_set1_ps(q.y()), qz = _mm256_set1_ps(q.z());
  const __m256 vh2 = _mm256_set1_ps(h2), vinvH = _mm256_set1_ps(invH), one = _mm256_set1_ps(1.0f);
  const __m256 zero = _mm256_setzero_ps();
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const Real *px = places.x, *py = places.y, *pz = places.z;
  const Real *vx = places.vx, *vy = places.vy, *vz = places.vz;
  __m256 w = zero, sx = zero, sy = zero, sz = zero;
  std::uint32_t neighbors = 0;
  for (std::uint32_t r = 0; r < rangeCount; ++r) {
    const std::uint32_t end = ranges[r].end;
    for (std::uint32_t j = ranges[r].begin; j < end; j += kLanes) {
      const __m256 dx = _mm256_sub_ps(qx, _mm256_loadu_ps(px + j));
      const __m256 dy = _mm256_sub_ps(qy, _mm256_loadu_ps(py + j));
      const __m256 dz = _mm256_sub_ps(qz, _mm256_loadu_ps(pz + j));
      const __m256 d2 =
          _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
      const __m256 inside = _mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32(int(end - j)), lane));
      const __m256 in = _mm256_and_ps(_mm256_cmp_ps(d2, vh2, _CMP_LE_OQ), inside);
      // No branch on an empty block (it would be mispredicted a quarter of the
      // time): it adds +0 to every lane.
      neighbors += std::uint32_t(__builtin_popcount(unsigned(_mm256_movemask_ps(in))));
      if constexpr (kVelocity) {
        const __m256 weight = _mm256_and_ps(
            in, _mm256_max_ps(_mm256_sub_ps(one, _mm256_mul_ps(_mm256_sqrt_ps(d2), vinvH)), zero));
        w = _mm256_add_ps(w, weight);
        sx = _mm256_add_ps(sx, _mm256_mul_ps(weight, _mm256_loadu_ps(vx + j)));
        sy = _mm256_add_ps(sy, _mm256_mul_ps(weight, _mm256_loadu_ps(vy + j)));
        sz = _mm256_add_ps(sz, _mm256_mul_ps(weight, _mm256_loadu_ps(vz + j)));
      }
    }
  }
  alignas(32) float lw[kLanes], lx[kLanes], ly[kLanes], lz[kLanes];
  _mm256_store_ps(lw, w);
  _mm256_store_ps(lx, sx);
  _mm256_store_ps(ly, sy);
  _mm256_store_ps(lz, sz);
  finish(neighbors, lw, lx, ly, lz, out);
}
#endif

} // namespace

void PlaceVelocities::gather(const search::UniformGridSearch& grid, const std::vector<Vec3r>& velocities) {
  // Padded with zeros: a lane past a range reads a finite velocity at weight 0.
  search::gatherScanPositions(velocities.data(), grid.placeOrder(), grid.pointCount(), x, y, z, Real(0));
}

void sampleFluid(const search::UniformGridSearch& grid, const PlaceVelocities* velocities, const Vec3r* positions,
                 std::size_t count, Real h, std::vector<FluidSample>& samples) {
  samples.assign(count, FluidSample{});
  if (count == 0 || grid.pointCount() == 0) return;
  const Places places{grid.placeX(),
                      grid.placeY(),
                      grid.placeZ(),
                      velocities ? velocities->x.data() : nullptr,
                      velocities ? velocities->y.data() : nullptr,
                      velocities ? velocities->z.data() : nullptr};
  const Real h2 = h * h, invH = Real(1) / h;
  const bool avx2 = search::searchUsesAvx2() && std::getenv("CASCADE_NO_AVX2") == nullptr;
  const bool withVelocity = velocities != nullptr;
  grid.forEachQueryGroup(positions, count, [&](const std::uint32_t* group, std::uint32_t size,
                                               const PlaceRange* ranges, std::uint32_t rangeCount) {
    for (std::uint32_t k = 0; k < size; ++k) {
      const std::uint32_t i = group[k];
      FluidSample& out = samples[i];
#ifdef CASCADE_SCAN_X86
      if (avx2) {
        if (withVelocity) sampleAvx2<true>(places, ranges, rangeCount, positions[i], h2, invH, out);
        else sampleAvx2<false>(places, ranges, rangeCount, positions[i], h2, invH, out);
        continue;
      }
#endif
      if (withVelocity) sampleBaseline<true>(places, ranges, rangeCount, positions[i], h2, invH, out);
      else sampleBaseline<false>(places, ranges, rangeCount, positions[i], h2, invH, out);
    }
  });
}

} // namespace cascade::whitewater
