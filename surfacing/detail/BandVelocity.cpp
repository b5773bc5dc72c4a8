#include "surfacing/detail/BandVelocity.h"

#include "surfacing/detail/BlockRasterizer.h"
#include "surfacing/detail/Profile.h"

#include <openvdb/tree/LeafManager.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <array>
#include <utility>

namespace cascade::surfacing::detail {

VelocityLeaves::~VelocityLeaves() {
  for (auto& leaves : mLeaves)
    for (LeafT* leaf : leaves) delete leaf;
}

void VelocityLeaves::add(const openvdb::Coord& origin, const float* weight, const float* sumX, const float* sumY,
                         const float* sumZ, float minWeight) {
  std::unique_ptr<LeafT> leaf;
  for (openvdb::Index i = 0; i < LeafT::SIZE; ++i) {
    if (!(weight[i] > minWeight)) continue;
    if (!leaf) leaf = std::make_unique<LeafT>(origin, openvdb::Vec3s(0.0f), false);
    const float inverse = 1.0f / weight[i];
    leaf->setValueOn(i, openvdb::Vec3s(sumX[i] * inverse, sumY[i] * inverse, sumZ[i] * inverse));
  }
  if (leaf) mLeaves.local().push_back(leaf.release());
}

openvdb::Vec3STree::Ptr VelocityLeaves::release() {
  auto tree = std::make_shared<openvdb::Vec3STree>(openvdb::Vec3s(0.0f));
  for (auto& leaves : mLeaves) {
    for (LeafT*& leaf : leaves) {
      tree->addLeaf(leaf);
      leaf = nullptr;
    }
    leaves.clear();
  }
  return tree;
}

openvdb::Vec3SGrid::Ptr velocityOverBand(const openvdb::FloatGrid& levelSet, const openvdb::Vec3STree& known,
                                         int sweeps) {
  using LeafT = openvdb::Vec3STree::LeafNodeType;
  ProfileClock profile;
  auto grid = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.0f));
  grid->setTransform(levelSet.transform().copy());
  grid->setName("v");
  grid->setIsInWorldSpace(true);
  grid->setVectorType(openvdb::VEC_CONTRAVARIANT_RELATIVE);  // a velocity: rotates, does not translate
  openvdb::Vec3STree& tree = grid->tree();
  tree.topologyUnion(levelSet.tree());
  tree.voxelizeActiveTiles();
  profile.lap("velocity: topology");

  // Known values in place; unknown band voxels switched off and listed per leaf.
  openvdb::tree::LeafManager<openvdb::Vec3STree> leaves(tree);
  const std::size_t leafCount = leaves.leafCount();
  std::vector<std::vector<openvdb::Index>> unknown(leafCount);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leafCount, 16), [&](const auto& range) {
    for (std::size_t l = range.begin(); l != range.end(); ++l) {
      LeafT& leaf = leaves.leaf(l);
      const LeafT* knownLeaf = known.probeConstLeaf(leaf.origin());
      for (auto voxel = leaf.beginValueOn(); voxel; ++voxel) {
        const openvdb::Index offset = voxel.pos();
        if (knownLeaf && knownLeaf->isValueOn(offset)) voxel.setValue(knownLeaf->getValue(offset));
        else unknown[l].push_back(offset);
      }
      for (openvdb::Index offset : unknown[l]) leaf.setValueOff(offset);
    }
  });
  profile.lap("velocity: known values");
  // The six face neighbours of every leaf (null where there is none): neighbour
  // voxels are read through them, not through tree look-ups.
  constexpr int D = LeafT::DIM;
  std::vector<std::array<const LeafT*, 6>> faceLeaves(leafCount);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leafCount, 64), [&](const auto& range) {
    for (std::size_t l = range.begin(); l != range.end(); ++l)
      for (int axis = 0, n = 0; axis < 3; ++axis)
        for (int side = -1; side <= 1; side += 2, ++n) {
          openvdb::Coord origin = leaves.leaf(l).origin();
          origin[axis] += side * D;
          faceLeaves[l][std::size_t(n)] = tree.probeConstLeaf(origin);
        }
  });

  // Sweeps: gather from the previous state, then commit.
  std::vector<std::vector<std::pair<openvdb::Index, openvdb::Vec3s>>> found(leafCount);
  std::vector<std::vector<openvdb::Index>> stillUnknown(leafCount);
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    const std::size_t resolved = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, leafCount, 16), std::size_t(0),
        [&](const auto& range, std::size_t count) {
          for (std::size_t l = range.begin(); l != range.end(); ++l) {
            found[l].clear();
            stillUnknown[l].clear();
            const LeafT& leaf = leaves.leaf(l);
            for (openvdb::Index offset : unknown[l]) {
              const int local[3] = {int(offset >> 6), int((offset >> 3) & 7), int(offset & 7)};
              const openvdb::Index stride[3] = {64, 8, 1};
              openvdb::Vec3s sum(0.0f);
              int count6 = 0;
              for (int axis = 0, n = 0; axis < 3; ++axis)
                for (int side = -1; side <= 1; side += 2, ++n) {
                  const int next = local[axis] + side;
                  const LeafT* owner = &leaf;
                  openvdb::Index neighbor;
                  if (next >= 0 && next < D) {
                    neighbor = side < 0 ? offset - stride[axis] : offset + stride[axis];
                  } else {  // across the face: the same voxel on the far side of the next leaf
                    owner = faceLeaves[l][std::size_t(n)];
                    if (!owner) continue;
                    neighbor = side < 0 ? offset + (D - 1) * stride[axis] : offset - (D - 1) * stride[axis];
                  }
                  if (owner->isValueOn(neighbor)) sum += owner->getValue(neighbor), ++count6;
                }
              if (count6 > 0) found[l].emplace_back(offset, sum / float(count6));
              else stillUnknown[l].push_back(offset);
            }
            count += found[l].size();
          }
          return count;
        },
        std::plus<std::size_t>());
    if (std::getenv("CASCADE_SURFACE_PROFILE")) {
      std::size_t left = 0;
      for (const auto& list : unknown) left += list.size();
      std::fprintf(stderr, "  profile velocity: sweep %d: %zu unknown, %zu resolved\n", sweep, left, resolved);
    }
    if (resolved == 0) break;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leafCount, 16), [&](const auto& range) {
      for (std::size_t l = range.begin(); l != range.end(); ++l) {
        if (found[l].empty()) continue;
        LeafT& leaf = leaves.leaf(l);
        for (const auto& [offset, value] : found[l]) leaf.setValueOn(offset, value);
        unknown[l].swap(stillUnknown[l]);
      }
    });
  }
  profile.lap("velocity: sweeps");
  // Whatever is left (no known voxel within the sweeps): the mean known value.
  std::size_t left = 0;
  for (const auto& list : unknown) left += list.size();
  if (left > 0) {
    openvdb::Vec3d sum(0.0);
    std::size_t count = 0;
    for (auto value = tree.cbeginValueOn(); value; ++value) sum += openvdb::Vec3d(*value), ++count;
    const openvdb::Vec3s mean = count > 0 ? openvdb::Vec3s(sum / double(count)) : openvdb::Vec3s(0.0f);
    for (std::size_t l = 0; l < leaves.leafCount(); ++l)
      for (openvdb::Index offset : unknown[l]) leaves.leaf(l).setValueOn(offset, mean);
  }
  return grid;
}

openvdb::Vec3STree::Ptr isotropicKernelVelocities(const std::vector<Vec3r>& center, const std::vector<Vec3r>& velocity,
                                                  double supportRadius, double voxelSize,
                                                  const std::vector<std::uint8_t>& interior) {
  using FloatLeaf = openvdb::FloatTree::LeafNodeType;
  constexpr int D = FloatLeaf::DIM;
  const std::vector<Eigen::Vector3f> half(center.size(), Eigen::Vector3f::Constant(float(supportRadius)));
  const std::vector<VoxelBox> boxes = supportVoxelBoxes(center, half, voxelSize);
  const float inverseR2 = float(1 / (supportRadius * supportRadius)), step = float(voxelSize);
  VelocityLeaves result;
  openvdb::FloatTree unused(0.0f);
  rasterizeBlocks(unused, center, boxes, interior, voxelSize,
                  [&](const openvdb::Coord& origin, const std::vector<std::uint32_t>& candidates, float*) {
    std::array<float, FloatLeaf::SIZE> weight{}, sumX{}, sumY{}, sumZ{};
    const Eigen::Vector3d originWorld = Eigen::Vector3d(origin.x(), origin.y(), origin.z()) * voxelSize;
    for (std::uint32_t k : candidates) {
      openvdb::Coord lo = boxes[k].lo, hi = boxes[k].hi;
      lo.maxComponent(origin);
      hi.minComponent(origin.offsetBy(D - 1));
      const Eigen::Vector3f p = (center[k].cast<double>() - originWorld).cast<float>();  // leaf-local
      const Eigen::Vector3f v = velocity[k].cast<float>();
      forEachVoxelInSphere(origin, lo, hi, p, inverseR2, step, [&](int i, float w) {
        weight[std::size_t(i)] += w;
        sumX[std::size_t(i)] += w * v.x();
        sumY[std::size_t(i)] += w * v.y();
        sumZ[std::size_t(i)] += w * v.z();
      });
    }
    result.add(origin, weight.data(), sumX.data(), sumY.data(), sumZ.data(), 0.0f);
    return false;  // no leaf in the float tree: the velocities are the product
  });
  return result.release();
}

std::vector<Vec3r> inSortedOrder(const std::vector<Vec3r>& values, const std::vector<std::uint32_t>& sortedIndex) {
  std::vector<Vec3r> sorted(sortedIndex.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, sortedIndex.size(), 8192), [&](const auto& range) {
    for (std::size_t k = range.begin(); k != range.end(); ++k) sorted[k] = values[sortedIndex[k]];
  });
  return sorted;
}

} // namespace cascade::surfacing::detail
