// The level-set methods' dispatch and the velocity sampler (LevelSetMethods.h).
#include "surfacing/LevelSetMethods.h"

#include "surfacing/detail/BandVelocity.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <limits>

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
  using Word = LeafT::NodeMaskType::Word;
  constexpr int kMask = int(LeafT::DIM) - 1;
  static_assert(LeafT::DIM == 8, "offsets (x << 6) | (y << 3) | z, a mask word per x");
  const double inverseDx = 1.0 / velocity.voxelSize()[0];
  const bool scaleOnly = velocity.transform().isLinear() &&
                         velocity.transform().worldToIndex(openvdb::Vec3d(0.0)).length() < 1e-9;
  std::vector<Eigen::Vector3f> result(points.size());
  // Mesh vertices come block by block, so consecutive points mostly share a leaf:
  // the leaf is looked up only when it changes. A cell inside its leaf with its 8
  // corners active (nearly every vertex) is read straight from the leaf's buffer
  // (corners at offsets 0, 1, 8, 9, 64, 65, 72, 73; its mask bits b, b + 1, b + 8,
  // b + 9 in the words of x and x + 1); any other cell goes corner by corner.
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 4096), [&](const auto& range) {
    auto access = velocity.getConstAccessor();
    const LeafT* leaf = nullptr;
    openvdb::Coord leafOrigin(std::numeric_limits<openvdb::Int32>::max());
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const Eigen::Vector3f& p = points[i];
      const openvdb::Vec3d world(p.x(), p.y(), p.z());
      const openvdb::Vec3d index = scaleOnly ? world * inverseDx : velocity.transform().worldToIndex(world);
      const openvdb::Coord cell = openvdb::Coord::floor(index);
      const openvdb::Vec3s f(index - cell.asVec3d());
      const float wx[2] = {1 - f.x(), f.x()}, wy[2] = {1 - f.y(), f.y()}, wz[2] = {1 - f.z(), f.z()};
      const openvdb::Coord origin(cell.x() & ~kMask, cell.y() & ~kMask, cell.z() & ~kMask);
      if (origin != leafOrigin) {
        leaf = access.probeConstLeaf(cell);
        leafOrigin = origin;
      }
      const int x = cell.x() & kMask, y = cell.y() & kMask, z = cell.z() & kMask;
      if (leaf && x < kMask && y < kMask && z < kMask) {
        const Word corners = Word(0x303) << ((y << 3) | z);
        const auto& mask = leaf->getValueMask();
        if ((mask.template getWord<Word>(openvdb::Index(x)) & corners) == corners &&
            (mask.template getWord<Word>(openvdb::Index(x + 1)) & corners) == corners) {
          const openvdb::Vec3s* v = leaf->buffer().data() + ((x << 6) | (y << 3) | z);
          const openvdb::Vec3s low = (v[0] * wz[0] + v[1] * wz[1]) * wy[0] + (v[8] * wz[0] + v[9] * wz[1]) * wy[1];
          const openvdb::Vec3s high =
              (v[64] * wz[0] + v[65] * wz[1]) * wy[0] + (v[72] * wz[0] + v[73] * wz[1]) * wy[1];
          const openvdb::Vec3s sum = low * wx[0] + high * wx[1];
          result[i] = Eigen::Vector3f(sum.x(), sum.y(), sum.z());
          continue;
        }
      }
      openvdb::Vec3s sum(0.0f);
      float weightSum = 0;
      for (int corner = 0; corner < 8; ++corner) {
        const int dx = corner >> 2, dy = (corner >> 1) & 1, dz = corner & 1;
        openvdb::Vec3s value;
        if (!access.probeValue(cell.offsetBy(dx, dy, dz), value)) continue;  // inactive: leaf voxel or tile
        const float w = wx[dx] * wy[dy] * wz[dz];
        sum += w * value;
        weightSum += w;
      }
      const openvdb::Vec3s v = weightSum > 0 ? sum / weightSum : openvdb::Vec3s(0.0f);
      result[i] = Eigen::Vector3f(v.x(), v.y(), v.z());
    }
  });
  return result;
}

} // namespace cascade::surfacing
