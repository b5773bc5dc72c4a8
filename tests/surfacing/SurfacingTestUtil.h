/// @file SurfacingTestUtil.h
/// @brief Particle arrangements and level-set probes shared by the surfacing tests.
#pragma once

#include "libsph/Types.h"

#include <openvdb/openvdb.h>
#include <openvdb/tools/Interpolation.h>

#include <cmath>
#include <cstdint>
#include <vector>

namespace cascade::test {

/// Deterministic jitter in [-amplitude, amplitude]^3 from an integer hash.
inline Vec3r jitter(std::uint32_t i, double amplitude) {
  auto h = [](std::uint32_t x) {
    x ^= x >> 16; x *= 0x7feb352dU; x ^= x >> 15; x *= 0x846ca68bU; x ^= x >> 16;
    return double(x) / 4294967295.0;
  };
  return Vec3r(Real((2 * h(3 * i + 1) - 1) * amplitude), Real((2 * h(3 * i + 2) - 1) * amplitude),
               Real((2 * h(3 * i + 3) - 1) * amplitude));
}

/// Cubic lattice points (spacing s) inside a ball of `radius` around `center`.
inline std::vector<Vec3r> latticeBall(const Vec3d& center, double radius, double s, double jitterAmplitude = 0) {
  std::vector<Vec3r> points;
  const int n = int(std::ceil(radius / s)) + 1;
  for (int i = -n; i <= n; ++i)
    for (int j = -n; j <= n; ++j)
      for (int k = -n; k <= n; ++k) {
        const Vec3d p = center + s * Vec3d(i + 0.5, j + 0.5, k + 0.5);
        if ((p - center).norm() <= radius)
          points.push_back(p.cast<Real>() + jitter(std::uint32_t(points.size()), jitterAmplitude));
      }
  return points;
}

/// Block of nx x ny x nz lattice points, the first centred at `corner` + s/2.
inline std::vector<Vec3r> latticeBlock(const Vec3d& corner, int nx, int ny, int nz, double s,
                                       double jitterAmplitude = 0) {
  std::vector<Vec3r> points;
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j)
      for (int k = 0; k < nz; ++k)
        points.push_back((corner + s * Vec3d(i + 0.5, j + 0.5, k + 0.5)).cast<Real>() +
                         jitter(std::uint32_t(points.size()), jitterAmplitude));
  return points;
}

/// Distance t along a ray from `origin` in `direction` where the level set crosses zero
/// (first sign change from inside to outside, refined by bisection); NaN if none.
inline double zeroCrossing(const openvdb::FloatGrid& grid, const Vec3d& origin, const Vec3d& direction,
                           double maxDistance) {
  openvdb::tools::GridSampler<openvdb::FloatGrid, openvdb::tools::BoxSampler> sampler(grid);
  auto phi = [&](double t) {
    const Vec3d p = origin + t * direction;
    return double(sampler.wsSample(openvdb::Vec3R(p.x(), p.y(), p.z())));
  };
  const double step = grid.voxelSize()[0] * 0.25;
  double a = 0, fa = phi(0);
  for (double t = step; t <= maxDistance; t += step) {
    const double ft = phi(t);
    if (fa < 0 && ft >= 0) {
      double b = t;
      for (int it = 0; it < 40; ++it) {
        const double m = 0.5 * (a + b);
        (phi(m) < 0 ? a : b) = m;
      }
      return 0.5 * (a + b);
    }
    a = t;
    fa = ft;
  }
  return std::nan("");
}

} // namespace cascade::test
