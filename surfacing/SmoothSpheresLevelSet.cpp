// Smooth spheres after Zhu & Bridson 2005 (LevelSetMethods.h).
#include "surfacing/AnisotropicKernels.h"
#include "surfacing/LevelSetMethods.h"
#include "surfacing/detail/BandVelocity.h"
#include "surfacing/detail/BlockRasterizer.h"
#include "surfacing/detail/ImplicitToLevelSet.h"

namespace cascade::surfacing {

// Calibrated (tests/surfacing: flat block, ball): with R = 2 spacings the weighted
// mean lies below the top layer, so a radius of 0.55 spacings puts the surface
// half a spacing above it.
const double kSmoothSpheresRadius = 0.55;

ParticleLevelSet smoothSpheresLevelSet(const std::vector<Vec3r>& positions, const LevelSetSettings& settings) {
  using LeafT = openvdb::FloatTree::LeafNodeType;
  const double s = settings.spacing, dx = settings.voxelSize;
  const double R = 2.0 * s;  // neighbourhood radius, "twice the particle spacing"
  const double radius = settings.radius > 0 ? settings.radius : kSmoothSpheresRadius * s;

  // Interior flags (full, balanced neighbourhoods) from the anisotropic-kernel pass.
  const ParticleGrid grid(positions, 2.1 * s);
  AnisotropicKernelSettings kernelSettings;
  kernelSettings.spacing = s;
  std::vector<std::uint8_t> interior;
  if (settings.skipInterior) interior = computeAnisotropicKernels(grid, kernelSettings).interior;
  const std::vector<Vec3r>& center = grid.sortedPosition();
  const std::vector<Eigen::Vector3f> half(center.size(), Eigen::Vector3f::Constant(float(R)));

  openvdb::FloatTree field(detail::kUndefinedField);
  const float inverseR2 = float(1 / (R * R)), step = float(dx);
  detail::rasterizeBlocks(field, center, half, interior, dx,
                          [&](const openvdb::Coord& origin, const std::vector<std::uint32_t>& candidates, float* out) {
    constexpr int D = LeafT::DIM;
    float weight[LeafT::SIZE] = {}, sumX[LeafT::SIZE] = {}, sumY[LeafT::SIZE] = {}, sumZ[LeafT::SIZE] = {};
    const Eigen::Vector3d originWorld = Eigen::Vector3d(origin.x(), origin.y(), origin.z()) * dx;
    for (std::uint32_t k : candidates) {
      openvdb::Coord lo, hi;
      detail::supportVoxelRange(center[k], half[k], dx, lo, hi);
      lo.maxComponent(origin);
      hi.minComponent(origin.offsetBy(D - 1));
      const Eigen::Vector3f p = (center[k].cast<double>() - originWorld).cast<float>();  // leaf-local
      detail::forEachVoxelInSphere(origin, lo, hi, p, inverseR2, step, [&](int i, float w) {
        weight[i] += w;
        sumX[i] += w * p.x();
        sumY[i] += w * p.y();
        sumZ[i] += w * p.z();
      });
    }
    bool any = false;
    for (int x = 0; x < D; ++x)
      for (int y = 0; y < D; ++y)
        for (int z = 0; z < D; ++z) {
          const int i = (x << 6) | (y << 3) | z;
          if (weight[i] <= 0) {
            out[i] = detail::kUndefinedField;
            continue;
          }
          any = true;
          const float inverse = 1 / weight[i];
          const float ex = float(x) * step - sumX[i] * inverse, ey = float(y) * step - sumY[i] * inverse,
                      ez = float(z) * step - sumZ[i] * inverse;
          out[i] = std::sqrt(ex * ex + ey * ey + ez * ez) - float(radius);  // Zhu & Bridson eq. 3
        }
    return any;
  });
  ParticleLevelSet result{detail::implicitToLevelSet(field, 0.0f, false, dx, settings.halfWidth), nullptr};
  if (settings.velocities)
    result.velocity = detail::isotropicKernelVelocities(
        center, detail::inSortedOrder(*settings.velocities, grid.sortedIndex()), R, dx, interior);
  return result;
}

} // namespace cascade::surfacing
