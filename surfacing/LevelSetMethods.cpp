// The level-set methods' dispatch and the velocity sampler (LevelSetMethods.h).
#include "surfacing/LevelSetMethods.h"

#include "surfacing/detail/BandVelocity.h"

#include <tbb/parallel_for.h>

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

openvdb::Vec3SGrid::Ptr velocityOverBand(const openvdb::FloatGrid& levelSet, const openvdb::Vec3STree& velocity,
                                         int halfWidth) {
  return detail::velocityOverBand(levelSet, velocity, detail::velocitySweeps(halfWidth));
}

std::vector<Eigen::Vector3f> sampleVelocity(const openvdb::Vec3SGrid& velocity,
                                            const std::vector<Eigen::Vector3f>& points) {
  // Trilinear in index space over the cell's active corners, renormalised: where
  // the band ends early (no kernel reached, so the level set holds its background
  // there) a corner of the cell a vertex lies in may be inactive. The lattice is
  // world aligned (index = world / dx), so the transform is a scale.
  const double inverseDx = 1.0 / velocity.voxelSize()[0];
  const bool scaleOnly = velocity.transform().isLinear() &&
                         velocity.transform().worldToIndex(openvdb::Vec3d(0.0)).length() < 1e-9;
  using LeafT = openvdb::Vec3STree::LeafNodeType;
  std::vector<Eigen::Vector3f> result(points.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 4096), [&](const auto& range) {
    auto access = velocity.getConstAccessor();
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const openvdb::Vec3d world(points[i].x(), points[i].y(), points[i].z());
      const openvdb::Vec3d index = scaleOnly ? world * inverseDx : velocity.transform().worldToIndex(world);
      const openvdb::Coord base = openvdb::Coord::floor(index);
      const openvdb::Vec3d f = index - base.asVec3d();
      openvdb::Vec3d sum(0.0);
      double weightSum = 0;
      auto add = [&](int corner, const openvdb::Vec3s& value) {
        const int dx = corner >> 2, dy = (corner >> 1) & 1, dz = corner & 1;
        const double w = (dx ? f.x() : 1 - f.x()) * (dy ? f.y() : 1 - f.y()) * (dz ? f.z() : 1 - f.z());
        sum += w * openvdb::Vec3d(value);
        weightSum += w;
      };
      const int mask = LeafT::DIM - 1;
      const LeafT* leaf = (base.x() & mask) < mask && (base.y() & mask) < mask && (base.z() & mask) < mask
                              ? access.probeConstLeaf(base)
                              : nullptr;
      if (leaf) {  // all eight corners in one leaf: read it directly
        const openvdb::Index first = LeafT::coordToOffset(base);
        for (int corner = 0; corner < 8; ++corner) {
          const openvdb::Index offset = first + openvdb::Index((corner >> 2) * 64 + ((corner >> 1) & 1) * 8 + (corner & 1));
          if (leaf->isValueOn(offset)) add(corner, leaf->getValue(offset));
        }
      } else {
        for (int corner = 0; corner < 8; ++corner) {
          openvdb::Vec3s value;
          if (access.probeValue(base.offsetBy(corner >> 2, (corner >> 1) & 1, corner & 1), value)) add(corner, value);
        }
      }
      const openvdb::Vec3d v = weightSum > 0 ? sum / weightSum : openvdb::Vec3d(0.0);
      result[i] = Eigen::Vector3f(float(v.x()), float(v.y()), float(v.z()));
    }
  });
  return result;
}

} // namespace cascade::surfacing
