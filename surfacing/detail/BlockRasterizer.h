/// @file BlockRasterizer.h
/// @brief Gathers compactly supported particle kernels into the 8^3 leaves of an
///        OpenVDB FloatGrid, one leaf per task, without atomics: each leaf adds
///        its candidate kernels in a fixed order, so the result is deterministic.
///
/// Leaves are created where a kernel's support box touches them; kernels flagged
/// `interior` (deep in the fluid) touch leaves only as contributors, not as
/// reasons to create a leaf, so the inside of a large body is never rasterized
/// (it becomes an inside tile after signedFloodFill). The voxel lattice is the
/// world lattice: voxel (i, j, k) is centred at (i, j, k) * voxelSize.
/// Internal to surfacing (includes OpenVDB).
#pragma once

#include "libsph/Types.h"
#include "surfacing/detail/Profile.h"

#include <openvdb/openvdb.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

namespace cascade::surfacing::detail {

/// Voxel index range [lo, hi] covered by a support box centred at `center` with half size `half`.
inline void supportVoxelRange(const Vec3r& center, const Eigen::Vector3f& half, double voxelSize,
                              openvdb::Coord& lo, openvdb::Coord& hi) {
  for (int k = 0; k < 3; ++k) {
    lo[k] = int(std::ceil((double(center[k]) - half[k]) / voxelSize));
    hi[k] = int(std::floor((double(center[k]) + half[k]) / voxelSize));
  }
}

/// A kernel's voxel index range [lo, hi] (supportVoxelRange).
struct VoxelBox {
  openvdb::Coord lo, hi;
};

/// supportVoxelRange of every kernel, computed once for all the passes that need it.
inline std::vector<VoxelBox> supportVoxelBoxes(const std::vector<Vec3r>& center,
                                               const std::vector<Eigen::Vector3f>& half, double voxelSize) {
  std::vector<VoxelBox> boxes(center.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, center.size(), 4096), [&](const auto& range) {
    for (std::size_t k = range.begin(); k != range.end(); ++k)
      supportVoxelRange(center[k], half[k], voxelSize, boxes[k].lo, boxes[k].hi);
  });
  return boxes;
}

/// Union boxes (voxel index ranges) of kernel supports per bin: an open-addressing
/// hash table of bin coordinates, load factor <= 1/2.
class BinBoxes {
public:
  struct Entry {
    openvdb::Coord bin, lo, hi;
    bool used = false;
  };
  /// Grows the box of `bin` by [lo, hi] (creating it as [lo, hi]).
  void add(const openvdb::Coord& bin, const openvdb::Coord& lo, const openvdb::Coord& hi) {
    if (2 * (mCount + 1) > mEntries.size()) grow();
    Entry& entry = find(bin);
    if (!entry.used) {
      entry = {bin, lo, hi, true};
      ++mCount;
      return;
    }
    entry.lo.minComponent(lo);
    entry.hi.maxComponent(hi);
  }
  const std::vector<Entry>& entries() const { return mEntries; }
  void swap(BinBoxes& other) noexcept {
    mEntries.swap(other.mEntries);
    std::swap(mCount, other.mCount);
  }

private:
  static std::uint64_t hash(const openvdb::Coord& bin) {  // splitmix64's finaliser of the packed coordinates
    std::uint64_t key = (std::uint64_t(std::uint32_t(bin.x())) << 42) ^ (std::uint64_t(std::uint32_t(bin.y())) << 21) ^
                        std::uint64_t(std::uint32_t(bin.z()));
    key = (key ^ (key >> 30)) * 0xBF58476D1CE4E5B9ull;
    key = (key ^ (key >> 27)) * 0x94D049BB133111EBull;
    return key ^ (key >> 31);
  }
  Entry& find(const openvdb::Coord& bin) {
    const std::size_t mask = mEntries.size() - 1;
    std::size_t slot = std::size_t(hash(bin)) & mask;
    while (mEntries[slot].used && mEntries[slot].bin != bin) slot = (slot + 1) & mask;
    return mEntries[slot];
  }
  void grow() {
    std::vector<Entry> old(std::max<std::size_t>(1024, 2 * mEntries.size()));
    old.swap(mEntries);
    for (const Entry& entry : old)
      if (entry.used) find(entry.bin) = entry;
  }
  std::vector<Entry> mEntries;
  std::size_t mCount = 0;
};

/// Rasterizes kernels into `tree`'s leaves. `accumulate(leafOrigin, candidates, values)`
/// fills 512 floats (VDB leaf order, z fastest) of one leaf from candidate kernel
/// slots (sorted); it returns false to leave the leaf out.
/// `center`, `boxes` (supportVoxelBoxes), `interior` describe the kernels
/// (interior may be empty).
template <class Accumulate>
void rasterizeBlocks(openvdb::FloatTree& tree, const std::vector<Vec3r>& center, const std::vector<VoxelBox>& boxes,
                     const std::vector<std::uint8_t>& interior, double voxelSize, const Accumulate& accumulate) {
  using LeafT = openvdb::FloatTree::LeafNodeType;
  const std::size_t n = center.size();
  if (n == 0) return;
  const double blockSize = LeafT::DIM * voxelSize;
  ProfileClock profile;

  // Leaves touched by the supports of non-interior kernels: per bin (block-sized
  // cell of kernel centres) the union of their support boxes, then every leaf of
  // each bin's union box. Bins are hash-table entries, filled in parallel over
  // chunks of kernels and merged (min/max: the same boxes in any order).
  const double inverseBlock = 1.0 / blockSize;
  auto binOf = [&](const Vec3r& c) {
    return openvdb::Coord(int(std::floor(double(c.x()) * inverseBlock)), int(std::floor(double(c.y()) * inverseBlock)),
                          int(std::floor(double(c.z()) * inverseBlock)));
  };
  const std::size_t binChunks = std::min<std::size_t>(8, (n + 65535) / 65536);
  std::vector<BinBoxes> binBoxes(binChunks);
  tbb::parallel_for(std::size_t(0), binChunks, [&](std::size_t c) {
    for (std::size_t k = c * n / binChunks; k < (c + 1) * n / binChunks; ++k) {
      if (!interior.empty() && interior[k]) continue;
      binBoxes[c].add(binOf(center[k]), boxes[k].lo, boxes[k].hi);
    }
  });
  for (std::size_t c = 1; c < binChunks; ++c) {
    for (const BinBoxes::Entry& entry : binBoxes[c].entries())
      if (entry.used) binBoxes[0].add(entry.bin, entry.lo, entry.hi);
    BinBoxes().swap(binBoxes[c]);
  }
  std::vector<openvdb::Coord> origins;
  if (binChunks > 0) {
    for (const BinBoxes::Entry& entry : binBoxes[0].entries()) {
      if (!entry.used) continue;
      const openvdb::Coord first = entry.lo & ~(LeafT::DIM - 1), last = entry.hi & ~(LeafT::DIM - 1);
      for (int x = first.x(); x <= last.x(); x += LeafT::DIM)
        for (int y = first.y(); y <= last.y(); y += LeafT::DIM)
          for (int z = first.z(); z <= last.z(); z += LeafT::DIM) origins.emplace_back(x, y, z);
    }
  }
  binBoxes.clear();
  tbb::parallel_sort(origins.begin(), origins.end());
  origins.erase(std::unique(origins.begin(), origins.end()), origins.end());

  profile.lap("blocks: leaf origins");
  // (leaf, kernel) pairs: every kernel lists the leaves its support box overlaps;
  // grouped by leaf, they give each leaf its candidates in kernel order (deterministic).
  // Leaf origin -> index: open addressing, load factor <= 1/2 (a binary search
  // per kernel and leaf cost more than the rest of the pairing).
  auto packLeaf = [](const openvdb::Coord& origin) {  // then splitmix64's finaliser: all bits mixed
    std::uint64_t key = (std::uint64_t(std::uint32_t(origin.x()) >> 3) << 42) ^
                        (std::uint64_t(std::uint32_t(origin.y()) >> 3) << 21) ^
                        std::uint64_t(std::uint32_t(origin.z()) >> 3);
    key = (key ^ (key >> 30)) * 0xBF58476D1CE4E5B9ull;
    key = (key ^ (key >> 27)) * 0x94D049BB133111EBull;
    return key ^ (key >> 31);
  };
  std::size_t tableSize = 16;
  while (tableSize < 2 * origins.size()) tableSize *= 2;
  const std::uint64_t tableMask = tableSize - 1;
  std::vector<std::int64_t> table(tableSize, -1);
  for (std::size_t b = 0; b < origins.size(); ++b) {
    std::uint64_t slot = packLeaf(origins[b]) & tableMask;
    while (table[slot] >= 0) slot = (slot + 1) & tableMask;
    table[slot] = std::int64_t(b);
  }
  auto leafIndex = [&](const openvdb::Coord& origin) -> std::int64_t {
    std::uint64_t slot = packLeaf(origin) & tableMask;
    for (std::int64_t b; (b = table[slot]) >= 0; slot = (slot + 1) & tableMask)
      if (origins[std::size_t(b)] == origin) return b;
    return -1;
  };
  const std::size_t chunk = 16384, chunks = (n + chunk - 1) / chunk;
  std::vector<std::vector<std::uint64_t>> chunkPairs(chunks);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks, 1), [&](const auto& range) {
    for (std::size_t c = range.begin(); c != range.end(); ++c) {
      auto& pairs = chunkPairs[c];
      for (std::size_t k = c * chunk; k < std::min(n, (c + 1) * chunk); ++k) {
        const openvdb::Coord& lo = boxes[k].lo;
        const openvdb::Coord& hi = boxes[k].hi;
        if (lo.x() > hi.x() || lo.y() > hi.y() || lo.z() > hi.z()) continue;
        const openvdb::Coord first = lo & ~(LeafT::DIM - 1), last = hi & ~(LeafT::DIM - 1);
        for (int x = first.x(); x <= last.x(); x += LeafT::DIM)
          for (int y = first.y(); y <= last.y(); y += LeafT::DIM)
            for (int z = first.z(); z <= last.z(); z += LeafT::DIM) {
              const std::int64_t leaf = leafIndex(openvdb::Coord(x, y, z));
              if (leaf >= 0) pairs.push_back((std::uint64_t(leaf) << 32) | std::uint64_t(k));
            }
      }
    }
  });
  // Counting sort by leaf, stable: chunks hold ascending kernels, so each leaf's
  // candidates come out in kernel order (as a sort of the pairs would give them).
  // Chunks are taken in groups, each group counting its own pairs per leaf and
  // scattering them from its own offsets, in parallel.
  const std::size_t leafCount = origins.size();
  const std::size_t groups = std::min<std::size_t>(chunks, 8), groupChunks = (chunks + groups - 1) / groups;
  std::vector<std::vector<std::uint32_t>> groupOffset(groups);
  tbb::parallel_for(std::size_t(0), groups, [&](std::size_t g) {
    std::vector<std::uint32_t>& count = groupOffset[g];
    count.assign(leafCount, 0);
    for (std::size_t c = g * groupChunks; c < std::min(chunks, (g + 1) * groupChunks); ++c)
      for (std::uint64_t pair : chunkPairs[c]) ++count[pair >> 32];
  });
  std::vector<std::size_t> leafStart(leafCount + 1);
  std::size_t total = 0;
  for (std::size_t b = 0; b < leafCount; ++b) {
    leafStart[b] = total;
    for (std::size_t g = 0; g < groups; ++g) {  // counts become each group's first slot
      const std::uint32_t count = groupOffset[g][b];
      groupOffset[g][b] = std::uint32_t(total);
      total += count;
    }
  }
  leafStart[leafCount] = total;
  if (total >= std::numeric_limits<std::uint32_t>::max())
    throw std::length_error("surfacing: too many (leaf, kernel) pairs");
  std::vector<std::uint32_t> pairKernel(total);
  tbb::parallel_for(std::size_t(0), groups, [&](std::size_t g) {
    std::vector<std::uint32_t>& next = groupOffset[g];
    for (std::size_t c = g * groupChunks; c < std::min(chunks, (g + 1) * groupChunks); ++c) {
      for (std::uint64_t pair : chunkPairs[c]) pairKernel[next[pair >> 32]++] = std::uint32_t(pair & 0xffffffffu);
      std::vector<std::uint64_t>().swap(chunkPairs[c]);
    }
  });

  profile.lap("blocks: pairs");
  std::vector<LeafT*> leaves(origins.size(), nullptr);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, origins.size(), 8), [&](const auto& range) {
    std::vector<std::uint32_t> candidates;
    alignas(64) std::array<float, LeafT::SIZE> values;  // accumulate may use aligned SIMD rows
    for (std::size_t b = range.begin(); b != range.end(); ++b) {
      candidates.clear();
      candidates.assign(pairKernel.begin() + std::ptrdiff_t(leafStart[b]),
                        pairKernel.begin() + std::ptrdiff_t(leafStart[b + 1]));
      std::fill(values.begin(), values.end(), 0.0f);
      if (!accumulate(origins[b], candidates, values.data())) continue;
      auto* leaf = new LeafT(origins[b], 0.0f, false);
      std::copy(values.begin(), values.end(), leaf->buffer().data());
      leaves[b] = leaf;
    }
  });
  profile.lap("blocks: accumulate");
  if (std::getenv("CASCADE_SURFACE_PROFILE"))
    std::fprintf(stderr, "  profile blocks: %zu leaves, %zu (leaf, kernel) pairs\n", origins.size(), pairKernel.size());
  for (LeafT* leaf : leaves)
    if (leaf) tree.addLeaf(leaf);
  profile.lap("blocks: add leaves");
}

/// Calls f(i, w) for every voxel of the leaf at `origin` (i its VDB offset) inside
/// the sphere of radius R around the kernel centre `p` (leaf-local, m), with
/// w = k(s) = (1 - s^2)^3, s = distance / R (Zhu & Bridson 2005); [lo, hi] is the
/// kernel's voxel box clipped to the leaf, `inverseR2` = 1 / R^2, `step` the voxel size.
template <class F>
void forEachVoxelInSphere(const openvdb::Coord& origin, const openvdb::Coord& lo, const openvdb::Coord& hi,
                          const Eigen::Vector3f& p, float inverseR2, float step, F&& f) {
  for (int x = lo.x(); x <= hi.x(); ++x) {
    const float dx = float(x - origin.x()) * step - p.x();
    for (int y = lo.y(); y <= hi.y(); ++y) {
      const float dy = float(y - origin.y()) * step - p.y();
      const float r2xy = (dx * dx + dy * dy) * inverseR2;
      if (r2xy >= 1) continue;
      const int row = ((x - origin.x()) << 6) | ((y - origin.y()) << 3);
      for (int z = lo.z(); z <= hi.z(); ++z) {
        const float dz = float(z - origin.z()) * step - p.z();
        const float r2 = r2xy + dz * dz * inverseR2;
        if (r2 >= 1) continue;
        const float t = 1 - r2;
        f(row | (z - origin.z()), t * t * t);
      }
    }
  }
}

/// The same from the kernels' support half sizes `half`.
template <class Accumulate>
void rasterizeBlocks(openvdb::FloatTree& tree, const std::vector<Vec3r>& center,
                     const std::vector<Eigen::Vector3f>& half, const std::vector<std::uint8_t>& interior,
                     double voxelSize, const Accumulate& accumulate) {
  rasterizeBlocks(tree, center, supportVoxelBoxes(center, half, voxelSize), interior, voxelSize, accumulate);
}

} // namespace cascade::surfacing::detail
