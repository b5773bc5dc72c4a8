#include "surfacing/detail/ImplicitToLevelSet.h"
#include "surfacing/detail/LeafNeighborhoods.h"
#include "surfacing/detail/Profile.h"

#include <openvdb/tools/Prune.h>
#include <openvdb/tools/SignedFloodFill.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <vector>
#include <cmath>
#include <cstdint>
#include <cstring>

namespace cascade::surfacing::detail {

namespace {

/// Leaf i of `input` and the face layers of its six neighbours into `f` (the
/// stencil below reads no edge or corner of the padding): whole 8-float rows
/// along z where the source has them.
void gatherFaces(const LeafNeighborhoods& input, std::size_t i, PaddedLeaf& f) {
  constexpr int D = kLeafDim;
  auto rows = [&](int n) -> const float* {
    const FloatLeaf* leaf = input.neighbor[i][std::size_t(n)];
    return leaf ? leaf->buffer().data() : nullptr;
  };
  const float* centre = rows(13);
  for (int x = 0; x < D; ++x)
    for (int y = 0; y < D; ++y) std::memcpy(&f[x + 1][y + 1][1], centre + ((x << 6) | (y << 3)), D * sizeof(float));
  // x faces (n = 4, 22) and y faces (n = 10, 16): rows along z; z faces (n = 12, 14): single values.
  for (int side = 0; side < 2; ++side) {
    const int n = side ? 22 : 4, from = side ? 0 : D - 1, to = side ? D + 1 : 0;
    if (const float* v = rows(n)) {
      for (int y = 0; y < D; ++y) std::memcpy(&f[to][y + 1][1], v + ((from << 6) | (y << 3)), D * sizeof(float));
    } else {
      for (int y = 0; y < D; ++y) std::fill_n(&f[to][y + 1][1], D, input.tileValue[i][std::size_t(n)]);
    }
  }
  for (int side = 0; side < 2; ++side) {
    const int n = side ? 16 : 10, from = side ? 0 : D - 1, to = side ? D + 1 : 0;
    if (const float* v = rows(n)) {
      for (int x = 0; x < D; ++x) std::memcpy(&f[x + 1][to][1], v + ((x << 6) | (from << 3)), D * sizeof(float));
    } else {
      for (int x = 0; x < D; ++x) std::fill_n(&f[x + 1][to][1], D, input.tileValue[i][std::size_t(n)]);
    }
  }
  for (int side = 0; side < 2; ++side) {
    const int n = side ? 14 : 12, from = side ? 0 : D - 1, to = side ? D + 1 : 0;
    const float* v = rows(n);
    const float tile = input.tileValue[i][std::size_t(n)];
    for (int x = 0; x < D; ++x)
      for (int y = 0; y < D; ++y) f[x + 1][y + 1][to] = v ? v[(x << 6) | (y << 3) | from] : tile;
  }
}

/// The constants of the stencil.
struct Stencil {
  float iso, sign, background, inverse2dx, inverseDx;
};

/// The signed distance estimate of one leaf from its padded field values `f` into
/// `out`, with the mask of |phi| < background. Compiled for AVX2 and for the
/// baseline; both give the same bits (the same IEEE operations, no contraction).
__attribute__((target_clones("avx2", "default")))
void levelSetLeaf(const PaddedLeaf& f, float* out, FloatLeaf::NodeMaskType& mask, const Stencil& stencil) {
  constexpr int D = kLeafDim;
  const float undefined = kUndefinedField;
  const float iso = stencil.iso, sign = stencil.sign, background = stencil.background;
  const float inverse2dx = stencil.inverse2dx, inverseDx = stencil.inverseDx;
  for (int x = 1; x <= D; ++x)
    for (int y = 1; y <= D; ++y) {
      const float* c = &f[x][y][1];
      const float *xm = &f[x - 1][y][1], *xp = &f[x + 1][y][1], *ym = &f[x][y - 1][1], *yp = &f[x][y + 1][1];
      float rowLargest = std::max(c[-1], c[D]);
      for (int z = 0; z < D; ++z)
        rowLargest = std::max(rowLargest, std::max(std::max(c[z], xm[z]), std::max(std::max(xp[z], ym[z]), yp[z])));
      if (rowLargest < undefined) {
        // The usual row: every value it needs defined, central differences throughout
        // (the same arithmetic as below, without a branch per voxel).
        float* o = out + (((x - 1) << 6) | ((y - 1) << 3));
        for (int z = 0; z < D; ++z) {
          const float gx = (xp[z] - xm[z]) * inverse2dx, gy = (yp[z] - ym[z]) * inverse2dx,
                      gz = (c[z + 1] - c[z - 1]) * inverse2dx;
          const float gradient = std::sqrt(gx * gx + gy * gy + gz * gz);
          const float difference = sign * (c[z] - iso);
          const float far = difference >= 0 ? background : -background;
          const float distance = gradient > 0 ? difference / (gradient > 0 ? gradient : 1.0f) : far;
          o[z] = std::abs(distance) < background ? distance : (distance > 0 ? background : -background);
        }
        std::uint64_t rowBits = 0;
        for (int z = 0; z < D; ++z) rowBits |= std::uint64_t(std::abs(o[z]) < background) << z;
        mask.getWord<std::uint64_t>(openvdb::Index(x - 1)) |= rowBits << ((y - 1) << 3);
        continue;
      }
      for (int z = 1; z <= D; ++z) {
        const int offset = ((x - 1) << 6) | ((y - 1) << 3) | (z - 1);
        const float value = f[x][y][z];
        if (value >= undefined) {
          out[offset] = background;
          continue;
        }
        // Central differences, one-sided next to undefined values.
        auto derivative = [&](float minus, float plus) {
          const bool hasMinus = minus < undefined, hasPlus = plus < undefined;
          if (hasMinus && hasPlus) return (plus - minus) * inverse2dx;
          if (hasPlus) return (plus - value) * inverseDx;
          if (hasMinus) return (value - minus) * inverseDx;
          return 0.0f;
        };
        const float gx = derivative(f[x - 1][y][z], f[x + 1][y][z]);
        const float gy = derivative(f[x][y - 1][z], f[x][y + 1][z]);
        const float gz = derivative(f[x][y][z - 1], f[x][y][z + 1]);
        const float gradient = std::sqrt(gx * gx + gy * gy + gz * gz);
        const float difference = sign * (value - iso);
        float distance;
        if (gradient > 0) distance = difference / gradient;
        else distance = difference >= 0 ? background : -background;
        if (std::abs(distance) < background) {
          out[offset] = distance;
          mask.setOn(openvdb::Index(offset));
        } else {
          out[offset] = distance > 0 ? background : -background;
        }
      }
    }
}

/// Prune, sign the inside and wrap `tree` (background already +-background) as a level-set grid.
openvdb::FloatGrid::Ptr finishLevelSet(openvdb::FloatTree::Ptr tree, double voxelSize) {
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

Stencil makeStencil(float iso, bool insideAbove, double voxelSize, int halfWidth) {
  return {iso, insideAbove ? -1.0f : 1.0f, float(halfWidth * voxelSize), float(0.5 / voxelSize), float(1 / voxelSize)};
}

} // namespace

openvdb::FloatGrid::Ptr implicitToLevelSet(const openvdb::FloatTree& field, float iso, bool insideAbove,
                                           double voxelSize, int halfWidth) {
  using LeafT = openvdb::FloatTree::LeafNodeType;
  const Stencil stencil = makeStencil(iso, insideAbove, voxelSize, halfWidth);
  auto tree = std::make_shared<openvdb::FloatTree>(field, stencil.background, openvdb::TopologyCopy());
  const LeafNeighborhoods input(field, kUndefinedField);
  std::vector<LeafT*> leaves;
  tree->getNodes(leaves);  // same topology, same order as input.leaves
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leaves.size(), 16), [&](const auto& range) {
    PaddedLeaf f = {};  // edges and corners stay unused
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      gatherFaces(input, i, f);
      LeafT& leaf = *leaves[i];
      LeafT::NodeMaskType mask;
      levelSetLeaf(f, leaf.buffer().data(), mask, stencil);
      leaf.setValueMask(mask);
    }
  });
  return finishLevelSet(tree, voxelSize);
}

openvdb::FloatGrid::Ptr implicitToLevelSet(openvdb::FloatTree::Ptr field, float iso, bool insideAbove,
                                           double voxelSize, int halfWidth) {
  using LeafT = openvdb::FloatTree::LeafNodeType;
  const Stencil stencil = makeStencil(iso, insideAbove, voxelSize, halfWidth);
  const LeafNeighborhoods input(*field, kUndefinedField);
  const std::size_t count = input.leaves.size();
  // Slabs of leaves of equal origin x, in ascending x. A leaf's stencil reads its
  // own slab and the two next to it, so slab s - 1 is overwritten (from scratch)
  // once slab s is done: two slabs of scratch instead of a second tree.
  std::vector<std::uint32_t> order(count);
  for (std::size_t i = 0; i < count; ++i) order[i] = std::uint32_t(i);
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return input.leaves[a]->origin().x() < input.leaves[b]->origin().x();
  });
  struct Result {
    alignas(32) float values[LeafT::SIZE];
    LeafT::NodeMaskType mask;
  };
  std::vector<Result> previous, current;
  std::size_t previousBegin = 0, previousEnd = 0;  // range of `order` held by `previous`
  auto writeBack = [&](const std::vector<Result>& results, std::size_t begin, std::size_t end) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(begin, end, 16), [&](const auto& range) {
      for (std::size_t j = range.begin(); j != range.end(); ++j) {
        auto& leaf = const_cast<LeafT&>(*input.leaves[order[j]]);
        std::memcpy(leaf.buffer().data(), results[j - begin].values, sizeof(float) * LeafT::SIZE);
        leaf.setValueMask(results[j - begin].mask);
      }
    });
  };
  for (std::size_t begin = 0; begin < count;) {
    std::size_t end = begin + 1;
    const int x = input.leaves[order[begin]]->origin().x();
    while (end < count && input.leaves[order[end]]->origin().x() == x) ++end;
    current.resize(end - begin);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(begin, end, 16), [&](const auto& range) {
      PaddedLeaf f = {};  // edges and corners stay unused
      for (std::size_t j = range.begin(); j != range.end(); ++j) {
        gatherFaces(input, order[j], f);
        Result& result = current[j - begin];
        result.mask.setOff();
        levelSetLeaf(f, result.values, result.mask, stencil);
      }
    });
    writeBack(previous, previousBegin, previousEnd);
    previous.swap(current);
    previousBegin = begin;
    previousEnd = end;
    begin = end;
  }
  writeBack(previous, previousBegin, previousEnd);
  // Inactive values are +-background already; internal tiles and the root take it
  // in pruneLevelSet and signedFloodFill.
  field->root().setBackground(stencil.background, /*updateChildNodes=*/false);
  return finishLevelSet(field, voxelSize);
}

} // namespace cascade::surfacing::detail
