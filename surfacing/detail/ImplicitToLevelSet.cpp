#include "surfacing/detail/ImplicitToLevelSet.h"
#include "surfacing/detail/Profile.h"

#include <openvdb/tools/Prune.h>
#include <openvdb/tools/SignedFloodFill.h>
#include <openvdb/tree/LeafManager.h>

#include <cmath>

namespace cascade::surfacing::detail {

openvdb::FloatGrid::Ptr implicitToLevelSet(const openvdb::FloatTree& field, float iso, bool insideAbove,
                                           double voxelSize, int halfWidth) {
  using LeafT = openvdb::FloatTree::LeafNodeType;
  constexpr int D = LeafT::DIM, P = D + 2;
  static_assert(D == 8, "leaf offsets below are (x << 6) | (y << 3) | z");
  const float background = float(halfWidth * voxelSize);
  auto tree = std::make_shared<openvdb::FloatTree>(field, background, openvdb::TopologyCopy());
  const float inverse2dx = float(0.5 / voxelSize), inverseDx = float(1 / voxelSize);

  openvdb::tree::LeafManager<openvdb::FloatTree> leaves(*tree);
  leaves.foreach([&](LeafT& leaf, std::size_t) {
    // Field values of the leaf and the face layers of its neighbours, padded by one.
    float padded[P][P][P];
    const float undefined = kUndefinedField;
    for (auto& plane : padded)
      for (auto& row : plane)
        for (float& v : row) v = undefined;
    const openvdb::Coord origin = leaf.origin();
    const float* self = field.probeConstLeaf(origin)->buffer().data();  // x-major, z fastest
    for (int x = 0; x < D; ++x)
      for (int y = 0; y < D; ++y)
        for (int z = 0; z < D; ++z) padded[x + 1][y + 1][z + 1] = self[(x << 6) | (y << 3) | z];
    for (int axis = 0; axis < 3; ++axis)
      for (int side = 0; side < 2; ++side) {
        openvdb::Coord neighborOrigin = origin;
        neighborOrigin[axis] += side ? D : -D;
        const LeafT* neighborLeaf = field.probeConstLeaf(neighborOrigin);
        if (!neighborLeaf) continue;  // stays undefined: one-sided differences
        const float* neighbor = neighborLeaf->buffer().data();
        const int layer = side ? 0 : D - 1;  // the neighbour's layer facing us
        const int target = side ? D + 1 : 0;
        for (int a = 0; a < D; ++a)
          for (int b = 0; b < D; ++b) {
            openvdb::Coord local;
            local[axis] = layer;
            local[(axis + 1) % 3] = a;
            local[(axis + 2) % 3] = b;
            int index[3];
            index[axis] = target;
            index[(axis + 1) % 3] = a + 1;
            index[(axis + 2) % 3] = b + 1;
            padded[index[0]][index[1]][index[2]] = neighbor[LeafT::coordToOffset(local)];
          }
      }
    const float sign = insideAbove ? -1.0f : 1.0f;
    for (int x = 0; x < D; ++x)
      for (int y = 0; y < D; ++y)
        for (int z = 0; z < D; ++z) {
          const openvdb::Index offset = LeafT::coordToOffset(openvdb::Coord(x, y, z));
          const float value = padded[x + 1][y + 1][z + 1];
          if (value >= undefined) {
            leaf.setValueOff(offset, background);
            continue;
          }
          const float centre = value;
          auto derivative = [&](float minus, float plus) {
            const bool hasMinus = minus < undefined, hasPlus = plus < undefined;
            if (hasMinus && hasPlus) return (plus - minus) * inverse2dx;
            if (hasPlus) return (plus - centre) * inverseDx;
            if (hasMinus) return (centre - minus) * inverseDx;
            return 0.0f;
          };
          const float gx = derivative(padded[x][y + 1][z + 1], padded[x + 2][y + 1][z + 1]);
          const float gy = derivative(padded[x + 1][y][z + 1], padded[x + 1][y + 2][z + 1]);
          const float gz = derivative(padded[x + 1][y + 1][z], padded[x + 1][y + 1][z + 2]);
          const float gradient = std::sqrt(gx * gx + gy * gy + gz * gz);
          const float difference = sign * (value - iso);
          float distance;
          if (gradient > 0) distance = difference / gradient;
          else distance = difference >= 0 ? background : -background;
          if (std::abs(distance) < background) leaf.setValueOn(offset, distance);
          else leaf.setValueOff(offset, distance > 0 ? background : -background);
        }
  });
  ProfileClock profile;
  openvdb::tools::pruneLevelSet(*tree);
  profile.lap("to level set: prune");
  openvdb::tools::signedFloodFill(*tree);
  profile.lap("to level set: flood fill");
  auto grid = openvdb::FloatGrid::create(tree);
  grid->setTransform(openvdb::math::Transform::createLinearTransform(voxelSize));
  grid->setGridClass(openvdb::GRID_LEVEL_SET);
  return grid;
}

} // namespace cascade::surfacing::detail
