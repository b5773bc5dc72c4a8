// Anisotropic kernels after Yu & Turk 2013 (LevelSetMethods.h, AnisotropicKernels.h).
#include "surfacing/AnisotropicKernels.h"
#include "surfacing/LevelSetMethods.h"
#include "surfacing/detail/BandVelocity.h"
#include "surfacing/detail/BlockRasterizer.h"
#include "surfacing/detail/ImplicitToLevelSet.h"
#include "surfacing/detail/Profile.h"

#include <cstring>

#include <tbb/parallel_for.h>

namespace cascade::surfacing {

// Calibrated (tests/surfacing: flat block, ball) with centre smoothing 0.5 and
// support 2 spacings: the flattened surface kernels fall off steeply, so the
// volume-keeping iso-value lies well below half the interior density.
const double kAnisotropicIso = 0.2;

namespace {

using LeafT = openvdb::FloatTree::LeafNodeType;
constexpr int kDim = LeafT::DIM;
static_assert(kDim == 8, "a leaf row is 8 floats");
/// One leaf row along z (GCC vector extension: one AVX register, or two SSE ones).
typedef float Row8 __attribute__((vector_size(32)));

/// Adds the density of kernels `candidates[0, count)` to the 512 values of the leaf
/// at `origin` (VDB order, z fastest), rows of 8 voxels along z at a time; with
/// `velocity` (per kernel), also the density-weighted velocity to `outVelocity`
/// (512 x, then 512 y, then 512 z).
/// Compiled for AVX2 (a row is one 8-float register) and for the baseline; both
/// give the same bits (the same IEEE operations in the same order, no contraction).
__attribute__((target_clones("avx2", "default")))
void accumulateLeaf(const AnisotropicKernels& kernels, const std::vector<detail::VoxelBox>& boxes, const openvdb::Coord& origin,
                    const std::uint32_t* candidates, std::size_t count, double dx, float* out,
                    const Eigen::Vector3f* velocity, float* outVelocity) {
  const float step = float(dx);
  const Row8 rowZ = {0, 1, 2, 3, 4, 5, 6, 7};
  const Eigen::Vector3d originWorld = Eigen::Vector3d(origin.x(), origin.y(), origin.z()) * dx;
  for (std::size_t c = 0; c < count; ++c) {
    const std::uint32_t k = candidates[c];
    openvdb::Coord lo = boxes[k].lo, hi = boxes[k].hi;
    lo.maxComponent(origin);
    hi.minComponent(origin.offsetBy(kDim - 1));
    const Eigen::Matrix3f& G = kernels.transform[k];
    const float weight = kernels.weight[k];
    const Eigen::Vector3f v = velocity ? velocity[k] : Eigen::Vector3f::Zero();
    const Eigen::Vector3f p = (kernels.center[k].cast<double>() - originWorld).cast<float>();
    // q = G d (Yu & Turk eq. 13: W = det(G) P(|G r|)) changes by G's columns times
    // the voxel size per voxel along x, y, z.
    const Eigen::Vector3f stepX = G.col(0) * step, stepY = G.col(1) * step, stepZ = G.col(2) * step;
    const float bb = stepZ.squaredNorm();
    const Row8 zzbb = rowZ * rowZ * bb;  // the z^2 |stepZ|^2 term of |q|^2 along a row
    const Eigen::Vector3f qFirst =  // q at (lo.x, lo.y, local z = 0)
        G * Eigen::Vector3f(float(lo.x() - origin.x()) * step - p.x(), float(lo.y() - origin.y()) * step - p.y(),
                            -p.z());
    // Along y, a = q at local z = 0 steps by stepY: a.stepZ steps by stepY.stepZ and
    // |a|^2 by a difference that itself grows by 2 |stepY|^2 (a quadratic, stepped).
    const float yz = stepY.dot(stepZ), yy2 = 2 * stepY.squaredNorm();
    for (int x = lo.x(); x <= hi.x(); ++x) {
      const Eigen::Vector3f column = qFirst + float(x - lo.x()) * stepX;  // a at y = lo.y
      float ab = column.dot(stepZ), aa = column.squaredNorm();
      float aaStep = 2 * column.dot(stepY) + 0.5f * yy2;
      for (int y = lo.y(); y <= hi.y(); ++y, ab += yz, aa += aaStep, aaStep += yy2) {
        // Every row of the support's box, and the whole row of the leaf, branch free
        // (voxels outside the support add 0): a test whether the row meets the
        // support (|a + z stepZ|^2 < 1 for some z) cost more in mispredicted
        // branches than the ~25 % of rows it skipped.
        // |q|^2 = |a|^2 + 2 z a.stepZ + z^2 |stepZ|^2: one multiply-add per voxel
        // instead of three components squared.
        float* row = out + (((x - origin.x()) << 6) | ((y - origin.y()) << 3));
        Row8 t = (Row8{} + (1.0f - aa) - (2.0f * ab) * rowZ) - zzbb, sum;
        t = t > 0.0f ? t : Row8{};
        const Row8 w = weight * t * t * t;
        std::memcpy(&sum, row, sizeof sum);
        sum += w;
        std::memcpy(row, &sum, sizeof sum);
        if (velocity) {  // the same weights, times the kernel's velocity (BandVelocity.h)
          const std::ptrdiff_t offset = row - out;
          for (int axis = 0; axis < 3; ++axis) {
            float* velocityRow = outVelocity + axis * 512 + offset;
            Row8 sumV;
            std::memcpy(&sumV, velocityRow, sizeof sumV);
            sumV += v[axis] * w;
            std::memcpy(velocityRow, &sumV, sizeof sumV);
          }
        }
      }
    }
  }
}

} // namespace

ParticleLevelSet anisotropicLevelSet(const std::vector<Vec3r>& positions, const LevelSetSettings& settings) {
  const double s = settings.spacing, dx = settings.voxelSize;
  AnisotropicKernelSettings kernelSettings;
  kernelSettings.spacing = s;
  if (settings.radius > 0) kernelSettings.supportRadius *= settings.radius / (0.5 * s);
  const double cellSize = std::max(kernelSettings.neighborRadius, kernelSettings.supportRadius) * s;
  detail::ProfileClock profile;
  const ParticleGrid grid(positions, cellSize);
  profile.lap("anisotropic: grid");
  const AnisotropicKernels kernels = computeAnisotropicKernels(grid, kernelSettings);
  std::vector<Eigen::Vector3f> velocity;  // per kernel (sorted slot): the particle's own
  if (settings.velocities) {
    velocity.resize(kernels.center.size());
    const std::vector<std::uint32_t>& index = grid.sortedIndex();
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, velocity.size(), 8192), [&](const auto& range) {
      for (std::size_t k = range.begin(); k != range.end(); ++k) velocity[k] = (*settings.velocities)[index[k]].cast<float>();
    });
  }
  profile.lap("anisotropic: kernels");
  static const std::vector<std::uint8_t> none;

  detail::VelocityLeaves velocityLeaves;

  auto field = std::make_shared<openvdb::FloatTree>(0.0f);
  const std::vector<detail::VoxelBox> boxes = detail::supportVoxelBoxes(kernels.center, kernels.halfExtent, dx);
  detail::rasterizeBlocks(*field, kernels.center, boxes, settings.skipInterior ? kernels.interior : none, dx,
                          [&](const openvdb::Coord& origin, const std::vector<std::uint32_t>& candidates, float* out) {
    if (velocity.empty()) {
      accumulateLeaf(kernels, boxes, origin, candidates.data(), candidates.size(), dx, out, nullptr, nullptr);
      return true;
    }
    alignas(64) float sums[3 * 512] = {};
    accumulateLeaf(kernels, boxes, origin, candidates.data(), candidates.size(), dx, out, velocity.data(), sums);
    // Known where the density is not negligible (1e-4 of the surface's iso-value):
    // the far tails of the widest kernels would bring velocities from further away.
    velocityLeaves.add(origin, out, sums, sums + 512, sums + 1024, float(1e-4 * kAnisotropicIso));
    return true;
  });
  profile.lap("anisotropic: rasterize blocks");
  ParticleLevelSet result{detail::implicitToLevelSet(field, float(kAnisotropicIso), true, dx, settings.halfWidth),
                          nullptr};
  profile.lap("anisotropic: to level set");
  if (!velocity.empty()) result.velocity = velocityLeaves.release();
  return result;
}

} // namespace cascade::surfacing
