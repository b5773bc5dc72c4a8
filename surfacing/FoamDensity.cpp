// Foam particles to a fog grid (FoamDensity.h).
#include "surfacing/FoamDensity.h"

#include "surfacing/detail/BlockRasterizer.h"

#include <cmath>

namespace cascade::surfacing {

openvdb::FloatGrid::Ptr foamDensityGrid(const std::vector<Vec3r>& foam, double spacing, double voxelSize) {
  using LeafT = openvdb::FloatTree::LeafNodeType;
  auto grid = openvdb::FloatGrid::create(0.0f);
  grid->setTransform(openvdb::math::Transform::createLinearTransform(voxelSize));
  grid->setName("foam");
  grid->setGridClass(openvdb::GRID_FOG_VOLUME);
  if (foam.empty()) return grid;
  const double R = spacing;
  // The integral of k over the ball of radius R is 4 pi R^3 * 16/315.
  const float scale = float(spacing * spacing * spacing / (4 * M_PI * R * R * R * 16.0 / 315.0));
  const std::vector<Eigen::Vector3f> half(foam.size(), Eigen::Vector3f::Constant(float(R)));
  const float inverseR2 = float(1 / (R * R)), step = float(voxelSize);
  openvdb::FloatTree& tree = grid->tree();
  detail::rasterizeBlocks(tree, foam, half, {}, voxelSize,
                          [&](const openvdb::Coord& origin, const std::vector<std::uint32_t>& candidates, float* out) {
    const Eigen::Vector3d originWorld = Eigen::Vector3d(origin.x(), origin.y(), origin.z()) * voxelSize;
    bool any = false;
    for (std::uint32_t k : candidates) {
      openvdb::Coord lo, hi;
      detail::supportVoxelRange(foam[k], half[k], voxelSize, lo, hi);
      lo.maxComponent(origin);
      hi.minComponent(origin.offsetBy(LeafT::DIM - 1));
      const Eigen::Vector3f p = (foam[k].cast<double>() - originWorld).cast<float>();  // leaf-local
      detail::forEachVoxelInSphere(origin, lo, hi, p, inverseR2, step, [&](int i, float w) {
        out[i] += scale * w;
        any = true;
      });
    }
    return any;
  });
  for (auto leaf = tree.beginLeaf(); leaf; ++leaf)
    for (openvdb::Index i = 0; i < LeafT::SIZE; ++i)
      if (leaf->getValue(i) > 0) leaf->setValueOn(i);
  tree.prune();
  return grid;
}

} // namespace cascade::surfacing
