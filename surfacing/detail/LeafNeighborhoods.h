/// @file LeafNeighborhoods.h
/// @brief The leaves of an OpenVDB FloatTree, each with its 26 neighbours, for
///        stencil passes that read a leaf padded by one voxel layer of its
///        neighbours and write a new buffer (no dependence on thread timing).
///        A missing neighbour reads as its tile value, or as a given constant.
/// Internal to surfacing (includes OpenVDB).
#pragma once

#include <openvdb/openvdb.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <optional>
#include <vector>

namespace cascade::surfacing::detail {

using FloatLeaf = openvdb::FloatTree::LeafNodeType;
constexpr int kLeafDim = FloatLeaf::DIM;      // 8
constexpr int kPaddedDim = kLeafDim + 2;      // padded by one voxel on each side
static_assert(kLeafDim == 8, "leaf offsets are (x << 6) | (y << 3) | z");
using PaddedLeaf = float[kPaddedDim][kPaddedDim][kPaddedDim];

/// The leaves of a tree with, for each, its 26 neighbours (or the tile value
/// that stands in for a missing one).
struct LeafNeighborhoods {
  std::vector<const FloatLeaf*> leaves;
  std::vector<std::array<const FloatLeaf*, 27>> neighbor;  // index (dx+1)*9 + (dy+1)*3 + (dz+1)
  std::vector<std::array<float, 27>> tileValue;

  /// `missing`, if set, is the value read where a neighbour leaf is missing (else its tile value).
  explicit LeafNeighborhoods(const openvdb::FloatTree& tree, std::optional<float> missing = std::nullopt) {
    tree.getNodes(leaves);
    neighbor.resize(leaves.size());
    tileValue.resize(leaves.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leaves.size(), 64), [&](const auto& range) {
      openvdb::tree::ValueAccessor<const openvdb::FloatTree> accessor(tree);
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        const openvdb::Coord origin = leaves[i]->origin();
        for (int n = 0; n < 27; ++n) {
          const openvdb::Coord at = origin.offsetBy((n / 9 - 1) * kLeafDim, (n / 3 % 3 - 1) * kLeafDim, (n % 3 - 1) * kLeafDim);
          const FloatLeaf* leaf = n == 13 ? leaves[i] : accessor.probeConstLeaf(at);
          neighbor[i][n] = leaf;
          tileValue[i][n] = leaf ? 0.0f : missing ? *missing : accessor.getValue(at);
        }
      }
    });
  }

  /// Values of leaf i and one voxel layer of its neighbours: padded[x + 1][y + 1][z + 1].
  void gather(std::size_t i, PaddedLeaf& padded) const {
    for (int n = 0; n < 27; ++n) {
      const int ox = n / 9 - 1, oy = n / 3 % 3 - 1, oz = n % 3 - 1;
      // Source range inside the neighbour and destination start in the padded block, per axis.
      auto range = [](int o, int& from, int& to, int& destination) {
        if (o < 0) from = kLeafDim - 1, to = kLeafDim, destination = 0;
        else if (o == 0) from = 0, to = kLeafDim, destination = 1;
        else from = 0, to = 1, destination = kLeafDim + 1;
      };
      int x0, x1, dx, y0, y1, dy, z0, z1, dz;
      range(ox, x0, x1, dx);
      range(oy, y0, y1, dy);
      range(oz, z0, z1, dz);
      const FloatLeaf* leaf = neighbor[i][n];
      if (leaf) {
        const float* v = leaf->buffer().data();
        for (int x = x0; x < x1; ++x)
          for (int y = y0; y < y1; ++y)
            for (int z = z0; z < z1; ++z) padded[dx + x - x0][dy + y - y0][dz + z - z0] = v[(x << 6) | (y << 3) | z];
      } else {
        const float value = tileValue[i][n];
        for (int x = x0; x < x1; ++x)
          for (int y = y0; y < y1; ++y)
            for (int z = z0; z < z1; ++z) padded[dx + x - x0][dy + y - y0][dz + z - z0] = value;
      }
    }
  }

  /// Runs step(i, padded, out) on every leaf with `out` a buffer of `scratch`
  /// (allocated on first use, one per leaf), then swaps the buffers into
  /// `targets` (the leaves of this tree, same order): no leaf changes while
  /// others read it, and the buffers are reused from step to step.
  template <class Step>
  void apply(const std::vector<FloatLeaf*>& targets, std::vector<FloatLeaf::Buffer>& scratch,
             const Step& step) const {
    scratch.resize(leaves.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leaves.size(), 16), [&](const auto& range) {
      PaddedLeaf padded;
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        gather(i, padded);
        step(i, padded, scratch[i].data());
      }
    });
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leaves.size(), 256), [&](const auto& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i) targets[i]->swap(scratch[i]);
    });
  }
};

} // namespace cascade::surfacing::detail
