// The level-set methods' dispatch and the velocity sampler (LevelSetMethods.h).
#include "surfacing/LevelSetMethods.h"

#include "surfacing/detail/BandVelocity.h"

#include <tbb/parallel_for.h>

#include <algorithm>

namespace cascade::surfacing {

ParticleLevelSet particlesToLevelSet(SurfaceMethod method, const std::vector<Vec3r>& positions,
                                     const LevelSetSettings& settings) {
  switch (method) {
    case SurfaceMethod::UnionOfSpheres: return unionOfSpheresLevelSet(positions, settings);
    case SurfaceMethod::SmoothSpheres: return smoothSpheresLevelSet(positions, settings);
    case SurfaceMethod::AnisotropicKernels: break;
  }
  return anisotropicLevelSet(positions, settings);
}

openvdb::Vec3SGrid::Ptr velocityOverBand(const openvdb::FloatGrid& levelSet, openvdb::Vec3STree::Ptr velocity,
                                         int halfWidth) {
  return detail::velocityOverBand(levelSet, std::move(velocity), detail::velocitySweeps(halfWidth));
}

std::vector<Eigen::Vector3f> sampleVelocity(const openvdb::Vec3SGrid& velocity,
                                            const std::vector<Eigen::Vector3f>& points) {
  // Trilinear in index space over the cell's active corners, renormalised: where
  // the band ends early (no kernel reached, so the level set holds its background
  // there) a corner of the cell a vertex lies in may be inactive. The lattice is
  // world aligned (index = world / dx), so the transform is a scale.
  using LeafT = openvdb::Vec3STree::LeafNodeType;
  constexpr int kMask = int(LeafT::DIM) - 1;
  const double inverseDx = 1.0 / velocity.voxelSize()[0];
  const bool scaleOnly = velocity.transform().isLinear() &&
                         velocity.transform().worldToIndex(openvdb::Vec3d(0.0)).length() < 1e-9;
  std::vector<Eigen::Vector3f> result(points.size());
  // In chunks: first every point's cell and leaf, with its corners' cache lines
  // prefetched, then the sums (the reads are memory bound; mesh vertices come
  // leaf by leaf, so the accessor mostly hits its cached leaf).
  constexpr std::size_t kChunk = 256;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 4096), [&](const auto& range) {
    auto access = velocity.getConstAccessor();
    openvdb::Coord base[kChunk];
    openvdb::Vec3s fraction[kChunk];
    const openvdb::Vec3s* cornerValues[kChunk][8];  // each corner's leaf: its values and mask (null: no leaf)
    const LeafT::NodeMaskType* cornerMask[kChunk][8];
    for (std::size_t first = range.begin(); first < range.end(); first += kChunk) {
      const std::size_t count = std::min(kChunk, range.end() - first);
      for (std::size_t j = 0; j < count; ++j) {
        const Eigen::Vector3f& p = points[first + j];
        const openvdb::Vec3d world(p.x(), p.y(), p.z());
        const openvdb::Vec3d index = scaleOnly ? world * inverseDx : velocity.transform().worldToIndex(world);
        const openvdb::Coord cell = openvdb::Coord::floor(index);
        base[j] = cell;
        fraction[j] = openvdb::Vec3s(index - cell.asVec3d());
        // Corners past the leaf's upper face along an axis lie in the next leaf.
        const int across = ((cell.x() & kMask) == kMask ? 4 : 0) | ((cell.y() & kMask) == kMask ? 2 : 0) |
                           ((cell.z() & kMask) == kMask ? 1 : 0);
        const LeafT* own = access.probeConstLeaf(cell);
        for (int corner = 0; corner < 8; ++corner) {
          const int step = corner & across;
          const LeafT* leaf = step == 0 ? own
                                        : access.probeConstLeaf(cell.offsetBy(step >> 2, (step >> 1) & 1, step & 1));
          cornerValues[j][corner] = leaf ? leaf->buffer().data() : nullptr;
          cornerMask[j][corner] = leaf ? &leaf->getValueMask() : nullptr;
          if (leaf && (corner & 1) == 0)  // z and z + 1 share a cache line but at the leaf's face
            __builtin_prefetch(cornerValues[j][corner] +
                               LeafT::coordToOffset(cell.offsetBy(corner >> 2, (corner >> 1) & 1, 0)));
        }
      }
      for (std::size_t j = 0; j < count; ++j) {
        const openvdb::Vec3s& f = fraction[j];
        const float wx[2] = {1 - f.x(), f.x()}, wy[2] = {1 - f.y(), f.y()}, wz[2] = {1 - f.z(), f.z()};
        openvdb::Vec3s sum(0.0f);
        float weightSum = 0;
        for (int corner = 0; corner < 8; ++corner) {
          const int dx = corner >> 2, dy = (corner >> 1) & 1, dz = corner & 1;
          const openvdb::Coord c = base[j].offsetBy(dx, dy, dz);
          const openvdb::Index at = LeafT::coordToOffset(c);
          const openvdb::Vec3s* values = cornerValues[j][corner];
          openvdb::Vec3s tile;
          if (!values) {  // no leaf there: an active tile's value, if any (grids from elsewhere)
            if (!access.probeValue(c, tile)) continue;
          } else if (!cornerMask[j][corner]->isOn(at)) {
            continue;
          }
          const float w = wx[dx] * wy[dy] * wz[dz];
          sum += w * (values ? values[at] : tile);
          weightSum += w;
        }
        const openvdb::Vec3s v = weightSum > 0 ? sum / weightSum : openvdb::Vec3s(0.0f);
        result[first + j] = Eigen::Vector3f(v.x(), v.y(), v.z());
      }
    }
  });
  return result;
}

} // namespace cascade::surfacing
