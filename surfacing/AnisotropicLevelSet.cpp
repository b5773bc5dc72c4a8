// Anisotropic kernels after Yu & Turk 2013 (LevelSetMethods.h, AnisotropicKernels.h).
#include "surfacing/AnisotropicKernels.h"
#include "surfacing/LevelSetMethods.h"
#include "surfacing/detail/BlockRasterizer.h"
#include "surfacing/detail/ImplicitToLevelSet.h"

#include <chrono>
#include <cstdio>
#include <cstdlib>

namespace cascade::surfacing {

// Calibrated (tests/surfacing: flat block, ball) with centre smoothing 0.5 and
// support 2 spacings: the flattened surface kernels fall off steeply, so the
// volume-keeping iso-value lies well below half the interior density.
const double kAnisotropicIso = 0.2;

openvdb::FloatGrid::Ptr anisotropicLevelSet(const std::vector<Vec3r>& positions,
                                            const LevelSetSettings& settings) {
  using LeafT = openvdb::FloatTree::LeafNodeType;
  const double s = settings.spacing, dx = settings.voxelSize;
  AnisotropicKernelSettings kernelSettings;
  kernelSettings.spacing = s;
  if (settings.radius > 0) kernelSettings.supportRadius *= settings.radius / (0.5 * s);
  const double cellSize = std::max(kernelSettings.neighborRadius, kernelSettings.supportRadius) * s;
  auto t0 = std::chrono::steady_clock::now();
  auto lap = [&](const char* what) {
    if (!getenv("CASCADE_PROFILE")) return;
    auto t1 = std::chrono::steady_clock::now();
    fprintf(stderr, "  %s %.1f ms\n", what, std::chrono::duration<double>(t1 - t0).count() * 1e3);
    t0 = t1;
  };
  const ParticleGrid grid(positions, cellSize);
  lap("grid");
  const AnisotropicKernels kernels = computeAnisotropicKernels(grid, kernelSettings);
  lap("kernels");
  static const std::vector<std::uint8_t> none;

  openvdb::FloatTree field(0.0f);
  const float step = float(dx);
  detail::rasterizeBlocks(field, kernels.center, kernels.halfExtent,
                          settings.skipInterior ? kernels.interior : none, dx,
                          [&](const openvdb::Coord& origin, const std::vector<std::uint32_t>& candidates, float* out) {
    constexpr int D = LeafT::DIM;
    const Eigen::Vector3d originWorld = Eigen::Vector3d(origin.x(), origin.y(), origin.z()) * dx;
    for (std::uint32_t k : candidates) {
      openvdb::Coord lo, hi;
      detail::supportVoxelRange(kernels.center[k], kernels.halfExtent[k], dx, lo, hi);
      lo.maxComponent(origin);
      hi.minComponent(origin.offsetBy(D - 1));
      const Eigen::Matrix3f& G = kernels.transform[k];
      const float weight = kernels.weight[k];
      const Eigen::Vector3f p = (kernels.center[k].cast<double>() - originWorld).cast<float>();
      const Eigen::Vector3f stepZ = G.col(2) * step;
      for (int x = lo.x(); x <= hi.x(); ++x)
        for (int y = lo.y(); y <= hi.y(); ++y) {
          const Eigen::Vector3f d(float(x - origin.x()) * step - p.x(), float(y - origin.y()) * step - p.y(),
                                  float(lo.z() - origin.z()) * step - p.z());
          Eigen::Vector3f q = G * d;  // Yu & Turk eq. 13: W(r, G) = det(G) P(|G r|)
          float* row = out + (((x - origin.x()) << 6) | ((y - origin.y()) << 3));
          for (int z = lo.z(); z <= hi.z(); ++z, q += stepZ) {
            const float r2 = q.squaredNorm();
            if (r2 >= 1) continue;
            const float t = 1 - r2;
            row[z - origin.z()] += weight * t * t * t;
          }
        }
    }
    return true;
  });
  lap("rasterize");
  if (getenv("CASCADE_PROFILE")) fprintf(stderr, "  leaves %zu\n", size_t(field.leafCount()));
  auto result = detail::implicitToLevelSet(field, float(kAnisotropicIso), true, dx, settings.halfWidth);
  lap("toLevelSet");
  return result;
}

} // namespace cascade::surfacing
