#include "surfacing/detail/BandVelocity.h"

#include "surfacing/detail/BlockRasterizer.h"
#include "surfacing/detail/Profile.h"

#include <openvdb/tools/Prune.h>
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
  LeafT::NodeMaskType known;
  for (openvdb::Index i = 0; i < LeafT::SIZE; ++i)
    if (weight[i] > minWeight) known.setOn(i);
  if (known.isOff()) return;
  auto leaf = std::make_unique<LeafT>(origin, openvdb::Vec3s(0.0f), false);
  openvdb::Vec3s* values = leaf->buffer().data();
  for (openvdb::Index i = 0; i < LeafT::SIZE; ++i) {  // unknown voxels keep the background, 0
    const float inverse = weight[i] > minWeight ? 1.0f / weight[i] : 0.0f;
    values[i] = openvdb::Vec3s(sumX[i] * inverse, sumY[i] * inverse, sumZ[i] * inverse);
  }
  leaf->setValueMask(known);
  mLeaves.local().push_back(leaf.release());
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

openvdb::Vec3SGrid::Ptr velocityOverBand(const openvdb::FloatGrid& levelSet, openvdb::Vec3STree::Ptr known, int sweeps) {
  using LeafT = openvdb::Vec3STree::LeafNodeType;
  using FloatLeaf = openvdb::FloatTree::LeafNodeType;
  using Mask = LeafT::NodeMaskType;
  using Word = Mask::Word;
  static_assert(LeafT::DIM == 8, "a mask word per x, bit (y << 3) | z");
  ProfileClock profile;
  if (!known) known = std::make_shared<openvdb::Vec3STree>(openvdb::Vec3s(0.0f));
  if (known->hasActiveTiles()) known->voxelizeActiveTiles();  // none from VelocityLeaves
  auto grid = openvdb::Vec3SGrid::create(known);
  known.reset();
  grid->setTransform(levelSet.transform().copy());
  grid->setName("v");
  grid->setIsInWorldSpace(true);
  grid->setVectorType(openvdb::VEC_CONTRAVARIANT_RELATIVE);  // a velocity: rotates, does not translate
  openvdb::Vec3STree& tree = grid->tree();
  const openvdb::Vec3s zero(0.0f);

  // The band's leaves (level sets keep no active tiles; voxelize any there are).
  const openvdb::FloatTree* band = &levelSet.tree();
  openvdb::FloatTree::Ptr voxelized;
  if (band->hasActiveTiles()) {
    voxelized = std::make_shared<openvdb::FloatTree>(*band);
    voxelized->voxelizeActiveTiles();
    band = voxelized.get();
  }
  std::vector<const FloatLeaf*> bandLeaves;
  bandLeaves.reserve(band->leafCount());
  for (auto leaf = band->cbeginLeaf(); leaf; ++leaf) bandLeaves.push_back(leaf.getLeaf());
  const std::size_t leafCount = bandLeaves.size();

  // The known tree's leaves become v's: a band leaf's known voxels keep their
  // values, its other voxels are unknown; known voxels outside the band go off
  // (to the background, so the file stays small). Band leaves no kernel reached
  // are made; leaves off the band are dropped.
  std::vector<LeafT*> leaves(leafCount, nullptr);
  std::vector<Mask> unknown(leafCount);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leafCount, 16), [&](const auto& range) {
    for (std::size_t l = range.begin(); l != range.end(); ++l) {
      const Mask& active = bandLeaves[l]->getValueMask();
      LeafT* leaf = tree.probeLeaf(bandLeaves[l]->origin());
      if (!leaf) {
        unknown[l] = active;
        continue;
      }
      leaves[l] = leaf;
      const Mask knownMask = leaf->getValueMask();
      unknown[l] = active & !knownMask;
      const Mask offBand = knownMask & !active;
      for (auto off = offBand.beginOn(); off; ++off) leaf->setValueOff(off.pos(), zero);
      leaf->setValueMask(knownMask & active);
    }
  });
  for (std::size_t l = 0; l < leafCount; ++l)
    if (!leaves[l]) {
      leaves[l] = new LeafT(bandLeaves[l]->origin(), zero, false);
      tree.addLeaf(leaves[l]);
    }
  std::vector<openvdb::Coord> offBand;
  for (auto leaf = tree.cbeginLeaf(); leaf; ++leaf)
    if (!band->probeConstLeaf(leaf->origin())) offBand.push_back(leaf->origin());
  for (const openvdb::Coord& origin : offBand) delete tree.stealNode<LeafT>(origin, zero, false);
  profile.lap("velocity: band leaves");

  // The six face neighbours of every leaf (null where there is none): neighbour
  // voxels are read through them, not through tree look-ups.
  constexpr int D = LeafT::DIM;
  std::vector<std::array<const LeafT*, 6>> faceLeaves(leafCount);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leafCount, 64), [&](const auto& range) {
    for (std::size_t l = range.begin(); l != range.end(); ++l)
      for (int axis = 0, n = 0; axis < 3; ++axis)
        for (int side = -1; side <= 1; side += 2, ++n) {
          openvdb::Coord origin = leaves[l]->origin();
          origin[axis] += side * D;
          faceLeaves[l][std::size_t(n)] = tree.probeConstLeaf(origin);
        }
  });

  // Sweeps (Jacobi: a sweep reads only voxels known before it). A voxel a sweep
  // resolves gets its value at once, which no one reads while it is off, and turns
  // on when the sweep is over.
  std::vector<Mask> resolved(leafCount);
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    const std::size_t resolvedCount = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, leafCount, 16), std::size_t(0),
        [&](const auto& range, std::size_t count) {
          for (std::size_t l = range.begin(); l != range.end(); ++l) {
            resolved[l].setOff();
            if (unknown[l].isOff()) continue;
            LeafT& leaf = *leaves[l];
            openvdb::Vec3s* values = leaf.buffer().data();
            // The known bits of this leaf and of its face neighbours (null: none), a
            // word per x: bit (y << 3) | z.
            const Mask& knownMask = leaf.getValueMask();
            const Mask* faceMask[6];
            const openvdb::Vec3s* faceValues[6];
            for (int n = 0; n < 6; ++n) {
              const LeafT* face = faceLeaves[l][std::size_t(n)];
              faceMask[n] = face ? &face->getValueMask() : nullptr;
              faceValues[n] = face ? face->buffer().data() : nullptr;
            }
            for (int x = 0; x < D; ++x) {
              Word todo = unknown[l].template getWord<Word>(openvdb::Index(x));
              while (todo != 0) {
                const int yz = __builtin_ctzll(todo);
                todo &= todo - 1;
                const int y = yz >> 3, z = yz & 7;
                const openvdb::Index offset = openvdb::Index((x << 6) | yz);
                openvdb::Vec3s sum(0.0f);
                int count6 = 0;
                // A neighbour in this leaf (at `delta` from offset), or across face n
                // (the same voxel on the far side of the next leaf, at `across`).
                auto add = [&](bool inside, int bit, int word, int delta, int n, int acrossBit, int acrossWord,
                               int across) {
                  if (inside) {
                    if ((knownMask.template getWord<Word>(openvdb::Index(word)) >> bit) & 1)
                      sum += values[int(offset) + delta], ++count6;
                  } else if (faceMask[n] &&
                             ((faceMask[n]->template getWord<Word>(openvdb::Index(acrossWord)) >> acrossBit) & 1)) {
                    sum += faceValues[n][int(offset) + across], ++count6;
                  }
                };
                // The order of BandVelocity's first version (x -, x +, y -, y +, z -, z +): the same sums.
                add(x > 0, yz, x - 1, -64, 0, yz, D - 1, (D - 1) * 64);
                add(x < D - 1, yz, x + 1, 64, 1, yz, 0, -(D - 1) * 64);
                add(y > 0, yz - 8, x, -8, 2, yz + (D - 1) * 8, x, (D - 1) * 8);
                add(y < D - 1, yz + 8, x, 8, 3, yz - (D - 1) * 8, x, -(D - 1) * 8);
                add(z > 0, yz - 1, x, -1, 4, yz + (D - 1), x, D - 1);
                add(z < D - 1, yz + 1, x, 1, 5, yz - (D - 1), x, -(D - 1));
                if (count6 == 0) continue;
                values[offset] = sum / float(count6);
                resolved[l].setOn(offset);
                ++count;
              }
            }
          }
          return count;
        },
        std::plus<std::size_t>());
    if (std::getenv("CASCADE_SURFACE_PROFILE")) {
      std::size_t left = 0;
      for (const Mask& mask : unknown) left += mask.countOn();
      std::fprintf(stderr, "  profile velocity: sweep %d: %zu unknown, %zu resolved\n", sweep, left, resolvedCount);
    }
    if (resolvedCount == 0) break;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leafCount, 64), [&](const auto& range) {
      for (std::size_t l = range.begin(); l != range.end(); ++l) {
        if (resolved[l].isOff()) continue;
        leaves[l]->setValueMask(leaves[l]->getValueMask() | resolved[l]);
        unknown[l] = unknown[l] & !resolved[l];
      }
    });
  }
  profile.lap("velocity: sweeps");
  // Whatever is left (no known voxel within the sweeps): the mean known value.
  std::size_t left = 0;
  for (const Mask& mask : unknown) left += mask.countOn();
  if (left > 0) {
    openvdb::Vec3d sum(0.0);
    std::size_t count = 0;
    for (auto value = tree.cbeginValueOn(); value; ++value) sum += openvdb::Vec3d(*value), ++count;
    const openvdb::Vec3s mean = count > 0 ? openvdb::Vec3s(sum / double(count)) : openvdb::Vec3s(0.0f);
    for (std::size_t l = 0; l < leafCount; ++l)
      for (auto on = unknown[l].beginOn(); on; ++on) leaves[l]->setValueOn(on.pos(), mean);
  }
  // Internal nodes the dropped leaves left empty (every band voxel is on by now).
  if (!offBand.empty()) openvdb::tools::pruneInactive(tree);
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
