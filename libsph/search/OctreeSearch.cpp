#include "libsph/search/OctreeSearch.h"

#include "libsph/search/CellKeys.h"
#include "libsph/search/Lattice.h"
#include "libsph/search/MortonCode.h"
#include "libsph/search/RadixSort.h"
#include "libsph/search/ScanRange.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

namespace cascade::search {

namespace {

constexpr int kLevels = 21;  ///< lattice 2^21 per axis: the finest octree level
constexpr std::int64_t kMaxLattice = kMortonMaxCoord;
constexpr std::uint32_t kNoIndex = std::numeric_limits<std::uint32_t>::max();
constexpr double kRangeMargin = 1e-5;  // see UniformGridSearch.cpp: covers float rounding
constexpr double kRangeSlack = 1e-20;
/// Subtrees over at most this many points are built by one task.
constexpr std::uint32_t kSerialBuild = 32768;

/// Morton digit (3 bits) of `key` that picks the child of a level-`level` node.
inline unsigned childDigit(std::uint64_t key, int level) {
  return static_cast<unsigned>((key >> (3 * (kLevels - 1 - level))) & 7u);
}

/// Level of the smallest octree cube holding both codes (kLevels if equal).
inline int commonLevel(std::uint64_t a, std::uint64_t b) {
  const std::uint64_t diff = a ^ b;
  if (!diff) return kLevels;
  const int highest = 63 - __builtin_clzll(diff);  // bit index
  return kLevels - 1 - highest / 3;
}

inline void cubeCorner(std::uint64_t key, int level, std::uint32_t corner[3]) {
  const int dropped = 3 * (kLevels - level);
  const std::uint64_t prefix = dropped >= 64 ? 0 : (key >> dropped) << dropped;
  mortonDecode(prefix, corner[0], corner[1], corner[2]);
}

/// Which of eight node boxes (lo/hi arrays from `first`) meet the query box.
struct BoxFilterBaseline {
  static inline unsigned mask8(const std::uint32_t* const lo[3], const std::uint32_t* const hi[3],
                               std::size_t first, const std::uint32_t queryLo[3],
                               const std::uint32_t queryHi[3]) {
    unsigned mask = 0;
    for (unsigned k = 0; k < 8; ++k) {
      const std::size_t c = first + k;
      const bool meets = lo[0][c] <= queryHi[0] && hi[0][c] >= queryLo[0] && lo[1][c] <= queryHi[1] &&
                         hi[1][c] >= queryLo[1] && lo[2][c] <= queryHi[2] && hi[2][c] >= queryLo[2];
      mask |= unsigned(meets) << k;
    }
    return mask;
  }

  /// Which children of a record meet the query box (overlap) and lie inside it (inside).
  static inline void childMasks(const OctreeSearch::ChildBlock& block, const std::uint32_t queryLo[3],
                                const std::uint32_t queryHi[3], unsigned& overlap, unsigned& inside) {
    overlap = inside = 0;
    for (unsigned k = 0; k < 8; ++k) {
      const std::uint32_t last = (std::uint32_t(1) << (kLevels - block.level[k])) - 1;
      bool meets = true, within = true;
      for (int a = 0; a < 3; ++a) {
        const std::uint32_t lo = block.lo[a][k], hi = lo + last;
        meets &= lo <= queryHi[a] && hi >= queryLo[a];
        within &= lo >= queryLo[a] && hi <= queryHi[a];
      }
      overlap |= unsigned(meets) << k;
      inside |= unsigned(within) << k;
    }
  }
  static inline unsigned leafMask(const OctreeSearch::ChildBlock& block) {
    unsigned mask = 0;
    for (unsigned k = 0; k < 8; ++k) mask |= unsigned(block.block[k] == OctreeSearch::kLeaf) << k;
    return mask;
  }
};

#ifdef CASCADE_SCAN_X86
struct BoxFilterAvx2 {
  // Lattice coordinates are below 2^21 (and the padding 2^30): signed compares are exact.
  __attribute__((target("avx2"))) static inline unsigned mask8(const std::uint32_t* const lo[3],
                                                               const std::uint32_t* const hi[3],
                                                               std::size_t first,
                                                               const std::uint32_t queryLo[3],
                                                               const std::uint32_t queryHi[3]) {
    __m256i outside = _mm256_setzero_si256();
    for (int a = 0; a < 3; ++a) {
      const __m256i nodeLo = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(lo[a] + first));
      const __m256i nodeHi = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(hi[a] + first));
      outside = _mm256_or_si256(
          outside, _mm256_cmpgt_epi32(nodeLo, _mm256_set1_epi32(static_cast<int>(queryHi[a]))));
      outside = _mm256_or_si256(
          outside, _mm256_cmpgt_epi32(_mm256_set1_epi32(static_cast<int>(queryLo[a])), nodeHi));
    }
    return ~static_cast<unsigned>(_mm256_movemask_ps(_mm256_castsi256_ps(outside))) & 0xffu;
  }

  __attribute__((target("avx2"))) static inline void childMasks(const OctreeSearch::ChildBlock& block,
                                                                const std::uint32_t queryLo[3],
                                                                const std::uint32_t queryHi[3],
                                                                unsigned& overlap, unsigned& inside) {
    // Cube edge - 1 per lane: 2^(21 - level) - 1.
    const __m256i level = _mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(block.level)));
    const __m256i one = _mm256_set1_epi32(1);
    const __m256i last =
        _mm256_sub_epi32(_mm256_sllv_epi32(one, _mm256_sub_epi32(_mm256_set1_epi32(kLevels), level)), one);
    __m256i outside = _mm256_setzero_si256(), notInside = _mm256_setzero_si256();
    for (int a = 0; a < 3; ++a) {
      const __m256i lo = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(block.lo[a]));
      const __m256i hi = _mm256_add_epi32(lo, last);
      const __m256i qlo = _mm256_set1_epi32(static_cast<int>(queryLo[a]));
      const __m256i qhi = _mm256_set1_epi32(static_cast<int>(queryHi[a]));
      outside = _mm256_or_si256(outside, _mm256_or_si256(_mm256_cmpgt_epi32(lo, qhi), _mm256_cmpgt_epi32(qlo, hi)));
      notInside =
          _mm256_or_si256(notInside, _mm256_or_si256(_mm256_cmpgt_epi32(qlo, lo), _mm256_cmpgt_epi32(hi, qhi)));
    }
    overlap = ~static_cast<unsigned>(_mm256_movemask_ps(_mm256_castsi256_ps(outside))) & 0xffu;
    inside = ~static_cast<unsigned>(_mm256_movemask_ps(_mm256_castsi256_ps(notInside))) & 0xffu;
  }
  __attribute__((target("avx2"))) static inline unsigned leafMask(const OctreeSearch::ChildBlock& block) {
    const __m256i child = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(block.block));
    return static_cast<unsigned>(
        _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(child, _mm256_set1_epi32(-1)))));
  }
};
#else
using BoxFilterAvx2 = BoxFilterBaseline;
#endif

} // namespace

void OctreeSearch::build(const Vec3r* points, std::size_t count, Real maxSupportRadius) {
  if (count >= std::size_t(kNoIndex))
    throw std::length_error("octree neighbour search: too many points (" + std::to_string(count) + ")");
  mPoints = points;
  mCount = count;
  mRadius = maxSupportRadius;
  mBlockCount = 0;

  const PointBounds bounds = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, count, 4096), PointBounds{},
      [&](const tbb::blocked_range<std::size_t>& range, PointBounds local) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) local.add(points[i]);
        return local;
      },
      [](PointBounds a, const PointBounds& b) {
        a.join(b);
        return a;
      });
  double edge = 0;
  for (int a = 0; a < 3; ++a) {
    mOrigin[a] = bounds.empty() ? 0.0 : bounds.lo[a];
    if (!bounds.empty()) edge = std::max(edge, bounds.hi[a] - bounds.lo[a]);
  }
  if (!(edge > 0) || !std::isfinite(edge)) edge = 1;
  mScale = double(kMaxLattice) / edge;

  // Morton codes of the points' lattice cells, sorted.
  mKeys.resize(count);
  mOrder.resize(count);
  std::iota(mOrder.begin(), mOrder.end(), 0u);
  cellKeys(points, count, mOrigin, mScale, mKeys.data());
  // Radix sort on the top 24 bits (the first eight levels), then each run of
  // equal top bits (a few points, in a compact fluid) sorted on the full code.
  constexpr int kTopBit = 3 * kLevels - 24;
  radixSortPairs(mKeys, mOrder, 3 * kLevels, mKeyScratch, mIndexScratch, kTopBit);
  {
    std::vector<std::uint32_t> runStart;
    for (std::size_t k = 0; k < count; ++k)
      if (k == 0 || (mKeys[k] >> kTopBit) != (mKeys[k - 1] >> kTopBit))
        runStart.push_back(static_cast<std::uint32_t>(k));
    runStart.push_back(static_cast<std::uint32_t>(count));
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, runStart.size() - 1, 1024), [&](const auto& range) {
      std::vector<std::pair<std::uint64_t, std::uint32_t>> pairs;
      for (std::size_t r = range.begin(); r != range.end(); ++r) {
        const std::uint32_t begin = runStart[r], end = runStart[r + 1];
        if (end - begin < 2) continue;
        if (end - begin <= 32) {  // insertion sort, stable
          for (std::uint32_t i = begin + 1; i < end; ++i) {
            const std::uint64_t key = mKeys[i];
            const std::uint32_t value = mOrder[i];
            std::uint32_t j = i;
            for (; j > begin && mKeys[j - 1] > key; --j) {
              mKeys[j] = mKeys[j - 1];
              mOrder[j] = mOrder[j - 1];
            }
            mKeys[j] = key;
            mOrder[j] = value;
          }
          continue;
        }
        pairs.resize(end - begin);
        for (std::uint32_t i = begin; i < end; ++i) pairs[i - begin] = {mKeys[i], mOrder[i]};
        std::stable_sort(pairs.begin(), pairs.end(),
                         [](const auto& a, const auto& b) { return a.first < b.first; });
        for (std::uint32_t i = begin; i < end; ++i) {
          mKeys[i] = pairs[i - begin].first;
          mOrder[i] = pairs[i - begin].second;
        }
      }
    });
  }

  gatherScanPositions(points, mOrder.data(), count, mX, mY, mZ);
  mOrder.resize(count + kScanPadding, kNoIndex);  // read (never reported) by the vector scans
  if (count == 0) return;

  // The tree. The root is the cube of the common prefix of all codes (the
  // levels above it would each have a single child).
  buildTree();
}

/// Writes the children of the node over places [begin, end), split at
/// `level` (the level of the smallest cube holding its points), into `block`;
/// innerChild(begin, end, level, lane) returns the record of an inner child's
/// own children (and schedules its split).
template <typename InnerChild>
void OctreeSearch::splitNode(ChildBlock& block, std::uint32_t begin, std::uint32_t end, int level,
                             InnerChild&& innerChild) const {
  const std::uint64_t* keys = mKeys.data();
  std::uint32_t corner[3];  // of this node's cube; a child one level down adds its digit's bits
  cubeCorner(keys[begin], level, corner);
  const std::uint32_t half = std::uint32_t(1) << (kLevels - level - 1);
  unsigned k = 0;
  std::uint32_t start = begin;
  while (start < end) {
    const unsigned digit = childDigit(keys[start], level);
    std::uint32_t stop;
    if (end - start <= 16) {
      stop = start + 1;
      while (stop < end && childDigit(keys[stop], level) == digit) ++stop;
    } else {
      stop = static_cast<std::uint32_t>(
          std::partition_point(keys + start, keys + end,
                               [&](std::uint64_t key) { return childDigit(key, level) <= digit; }) -
          keys);
    }
    // A child with more points than a leaf holds is split in its turn, at the
    // level where its codes differ (the chain of one-child cubes above is
    // skipped); points in one lattice cell cannot be split and share a leaf.
    int childLevel = level + 1;
    bool inner = false;
    if (stop - start > mLeafSize) {
      const int common = commonLevel(keys[start], keys[stop - 1]);
      if (common < kLevels) {
        inner = true;
        childLevel = common;
      }
    }
    if (childLevel == level + 1) {
      for (int a = 0; a < 3; ++a) block.lo[a][k] = corner[a] | (((digit >> a) & 1u) * half);
      block.begin[k] = start;
      block.level[k] = static_cast<std::uint8_t>(childLevel);
    } else {
      setLane(block, k, start, childLevel, keys[start]);
    }
    block.block[k] = inner ? innerChild(start, stop, childLevel, k) : kLeaf;
    ++k;
    start = stop;
  }
  closeBlock(block, k, end);
}

void OctreeSearch::setLane(ChildBlock& block, unsigned lane, std::uint32_t begin, int level,
                           std::uint64_t key) {
  std::uint32_t corner[3];
  cubeCorner(key, level, corner);
  for (int a = 0; a < 3; ++a) block.lo[a][lane] = corner[a];
  block.begin[lane] = begin;
  block.level[lane] = static_cast<std::uint8_t>(level);
}

void OctreeSearch::closeBlock(ChildBlock& block, unsigned used, std::uint32_t end) {
  for (unsigned k = 0; k < 8; ++k) {
    if (k < used) continue;
    for (int a = 0; a < 3; ++a) block.lo[a][k] = 1u << 30;  // meets no query box
    block.begin[k] = end;
    block.level[k] = kLevels;
    block.block[k] = kLeaf;
  }
  block.begin[8] = end;
}

void OctreeSearch::buildTree() {
  const std::uint32_t count = static_cast<std::uint32_t>(mCount);
  struct Pending {
    std::uint32_t begin, end;
    int level;
    std::uint32_t block;  ///< where its children go
  };
  // Record 0: the root alone.
  ChildBlock rootBlock;
  const int rootLevel = commonLevel(mKeys.front(), mKeys.back());
  const bool rootInner = count > mLeafSize && rootLevel < kLevels;
  setLane(rootBlock, 0, 0, rootLevel, mKeys.front());
  rootBlock.block[0] = kLeaf;
  closeBlock(rootBlock, 1, count);

  // Top of the tree breadth first, one record per inner node, until the nodes
  // are small enough to be built by one task each (deferred); then those
  // subtrees in parallel. An inner node has at least two children, so a
  // subtree over n points has at most n - 1 inner nodes: each deferred
  // subtree writes its records into a region of that size, its root's record
  // first (regions are not filled up; the rest stays untouched memory).
  std::vector<ChildBlock> top{rootBlock};
  std::vector<Pending> frontier, deferred;
  std::vector<std::pair<std::uint32_t, unsigned>> deferredLane;  // (top record, lane)
  auto topChild = [&](std::uint32_t parent) {
    return [&, parent](std::uint32_t begin, std::uint32_t end, int level, unsigned lane) {
      if (end - begin > kSerialBuild) {
        const std::uint32_t index = static_cast<std::uint32_t>(top.size() + frontier.size());
        frontier.push_back(Pending{begin, end, level, index});
        return index;
      }
      deferred.push_back(Pending{begin, end, level, 0});
      deferredLane.emplace_back(parent, lane);
      return kLeaf;  // patched below
    };
  };
  if (rootInner) top[0].block[0] = topChild(0)(0, count, rootLevel, 0);
  while (!frontier.empty()) {
    std::vector<Pending> current;
    current.swap(frontier);
    const std::size_t firstNew = top.size();
    top.resize(top.size() + current.size());
    for (std::size_t i = 0; i < current.size(); ++i) {
      const Pending& node = current[i];
      ChildBlock block;
      splitNode(block, node.begin, node.end, node.level, topChild(static_cast<std::uint32_t>(firstNew + i)));
      top[firstNew + i] = block;
    }
  }

  std::vector<std::uint32_t> region(deferred.size() + 1);
  region[0] = static_cast<std::uint32_t>(top.size());
  for (std::size_t d = 0; d < deferred.size(); ++d) {
    const std::uint64_t next = std::uint64_t(region[d]) + (deferred[d].end - deferred[d].begin - 1);
    if (next >= std::uint64_t(kLeaf)) throw std::length_error("octree: too many nodes");
    region[d + 1] = static_cast<std::uint32_t>(next);
  }
  mBlockCount = region.back();
  if (mBlockCount > mBlockCapacity) {
    // Default-initialised (untouched) memory: the pages a build does not use
    // are never committed.
    mBlocks.reset(new ChildBlock[mBlockCount]);
    mBlockCapacity = mBlockCount;
  }
  ChildBlock* blocks = mBlocks.get();
  for (std::size_t d = 0; d < deferred.size(); ++d)
    top[deferredLane[d].first].block[deferredLane[d].second] = region[d];
  std::copy(top.begin(), top.end(), blocks);

  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, deferred.size(), 1), [&](const auto& range) {
    std::vector<Pending> stack, children;
    for (std::size_t d = range.begin(); d != range.end(); ++d) {
      std::uint32_t next = region[d] + 1;
      stack.assign(1, Pending{deferred[d].begin, deferred[d].end, deferred[d].level, region[d]});
      while (!stack.empty()) {
        const Pending node = stack.back();
        stack.pop_back();
        children.clear();
        splitNode(blocks[node.block], node.begin, node.end, node.level,
                  [&](std::uint32_t begin, std::uint32_t end, int level, unsigned) {
                    children.push_back(Pending{begin, end, level, next});
                    return next++;
                  });
        // First child on top: the records follow the curve depth first.
        stack.insert(stack.end(), children.rbegin(), children.rend());
      }
    }
  });
}

std::vector<OctreeSearch::Node> OctreeSearch::nodes() const {
  std::vector<Node> nodes;
  if (mCount == 0) return nodes;
  // Breadth first from the root; children of a node contiguous.
  struct Entry {
    std::uint32_t block;  ///< record of the node's children, or kLeaf
  };
  std::vector<Entry> entries;
  const ChildBlock& root = mBlocks[0];
  Node rootNode{};
  for (int a = 0; a < 3; ++a) rootNode.corner[a] = root.lo[a][0];
  rootNode.begin = root.begin[0];
  rootNode.end = root.begin[1];
  rootNode.level = root.level[0];
  nodes.push_back(rootNode);
  entries.push_back(Entry{root.block[0]});
  for (std::size_t n = 0; n < nodes.size(); ++n) {
    if (entries[n].block == kLeaf) continue;
    const ChildBlock& block = mBlocks[entries[n].block];
    nodes[n].firstChild = static_cast<std::uint32_t>(nodes.size());
    for (unsigned k = 0; k < 8 && block.lo[0][k] != (1u << 30); ++k) {
      Node child{};
      for (int a = 0; a < 3; ++a) child.corner[a] = block.lo[a][k];
      child.begin = block.begin[k];
      child.end = block.begin[k + 1];
      child.level = block.level[k];
      nodes.push_back(child);
      entries.push_back(Entry{block.block[k]});
      ++nodes[n].childCount;
    }
  }
  return nodes;
}

std::size_t OctreeSearch::nodeCount() const { return nodes().size(); }

std::size_t OctreeSearch::largestLeaf() const {
  std::size_t largest = 0;
  for (const Node& node : nodes())
    if (!node.childCount) largest = std::max<std::size_t>(largest, node.end - node.begin);
  return largest;
}

int OctreeSearch::depth() const {
  int deepest = 0;
  for (const Node& node : nodes()) deepest = std::max<int>(deepest, node.level);
  return deepest;
}

/// One query() call: the walks of a chunk of queries.
struct OctreeQuery {
  const OctreeSearch& tree;
  const Vec3r* queries;
  const Real* radii;
  bool excludeSelf;
  bool self;
  const std::uint32_t* queryOrder;

  template <typename Scan, typename BoxFilter, bool MergeRuns = true>
  void runChunk(std::uint32_t placeBegin, std::uint32_t placeEnd, ChunkWriter& writer) const;
};

CASCADE_SEARCH_AVX2_TARGET void runOctreeChunkAvx2(const OctreeQuery& job, std::uint32_t placeBegin,
                                                    std::uint32_t placeEnd, ChunkWriter& writer);

void OctreeSearch::query(const Vec3r* queries, std::size_t count, const Real* supportRadii,
                         bool excludeSelf, NeighborLists& out) const {
  if (count == 0 || mCount == 0) {
    out.setEmpty(count);
    return;
  }
  if (count >= std::size_t(kNoIndex))
    throw std::length_error("octree neighbour search: too many queries (" + std::to_string(count) + ")");
  std::unique_lock<std::mutex> lock(mScratchMutex, std::try_to_lock);
  ListScratch localScratch;
  ListScratch& scratch = lock.owns_lock() ? mScratch : localScratch;

  // Queries along the Z curve: consecutive queries walk the same branches.
  const bool self = queries == mPoints && count == mCount;
  std::vector<std::uint32_t> ownOrder;
  const std::uint32_t* queryOrder = mOrder.data();
  if (!self) {
    std::vector<std::uint64_t> keys(count), keyScratch;
    std::vector<std::uint32_t> indexScratch;
    ownOrder.resize(count);
    std::iota(ownOrder.begin(), ownOrder.end(), 0u);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 8192), [&](const auto& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        std::uint32_t c[3];
        for (int a = 0; a < 3; ++a)
          c[a] = clampToLattice(latticeFloor((double(queries[i][a]) - mOrigin[a]) * mScale));
        keys[i] = mortonEncode(c[0], c[1], c[2]);
      }
    });
    // Coherence only needs the first eight levels of the curve.
    radixSortPairs(keys, ownOrder, 3 * kLevels, keyScratch, indexScratch, 3 * kLevels - 24);
    queryOrder = ownOrder.data();
  }
  const std::uint32_t chunkSize = static_cast<std::uint32_t>(std::max<std::size_t>(512, count / 256));
  std::vector<std::uint32_t> chunkStart;
  for (std::size_t s = 0; s < count; s += chunkSize) chunkStart.push_back(static_cast<std::uint32_t>(s));
  chunkStart.push_back(static_cast<std::uint32_t>(count));

  const OctreeQuery job{*this, queries, supportRadii, excludeSelf, self, queryOrder};
  const bool avx2 = searchUsesAvx2();
  assembleLists(count, queryOrder, chunkStart, scratch, out,
                [&](std::size_t, std::uint32_t placeBegin, std::uint32_t placeEnd, ChunkWriter& writer) {
                  if (avx2)
                    runOctreeChunkAvx2(job, placeBegin, placeEnd, writer);
                  else
                    job.runChunk<ScanBaseline, BoxFilterBaseline>(placeBegin, placeEnd, writer);
                });
}

template <typename Scan, typename BoxFilter, bool MergeRuns>
void OctreeQuery::runChunk(std::uint32_t placeBegin, std::uint32_t placeEnd, ChunkWriter& writer) const {
  const Real* xs = tree.mX.data();
  const Real* ys = tree.mY.data();
  const Real* zs = tree.mZ.data();
  const std::uint32_t* order = tree.mOrder.data();
  const OctreeSearch::ChildBlock* blocks = tree.mBlocks.get();
  const double* origin = tree.mOrigin;
  const double scale = tree.mScale;

  // A few consecutive queries (neighbours along the Z curve) walk the tree
  // together with the box around all their cubes; the walk collects the nodes
  // it reaches (leaves, and nodes inside that box), then each query keeps those
  // whose cube overlaps its own cube and tests their particles exactly. The
  // result is the per-query walk's: a particle is tested iff its leaf or an
  // ancestor overlaps the query's cube.
  constexpr int kGroup = 64;
  struct Query {
    Real x, y, z, radius2;
    std::uint32_t index, exclude;
    std::uint32_t lo[3], hi[3];
    bool empty;
  };
  Query group[kGroup];
  std::vector<std::uint32_t> runBegins, runEnds;
  std::vector<std::uint32_t> candidateLo[3], candidateHi[3];
  struct Frame {
    std::uint32_t block;
    unsigned pending;  ///< children still to visit (those meeting the box)
    unsigned collect;  ///< of those, the ones collected without descent
  };
  Frame frames[kLevels + 3];  // one per level on the path from the root record

  auto makeQuery = [&](std::uint32_t place, Query& query) {
    const std::uint32_t q = queryOrder[place];
    query.index = q;
    if (self) {
      query.x = xs[place];
      query.y = ys[place];
      query.z = zs[place];
    } else {
      query.x = queries[q].x();
      query.y = queries[q].y();
      query.z = queries[q].z();
    }
    const Real radius = radii ? radii[q] : tree.mRadius;
    query.radius2 = radius * radius;
    query.exclude = excludeSelf ? q : kNoIndex;
    // The query cube of edge 2 x radius (SEED 2.1: 2 kappa h_i), on the lattice.
    const double reach = std::fabs(double(radius)) * (1.0 + kRangeMargin) + kRangeSlack;
    const double position[3] = {double(query.x), double(query.y), double(query.z)};
    query.empty = !(reach >= 0);
    for (int a = 0; a < 3; ++a) {
      const std::int64_t low = latticeFloor((position[a] - reach - origin[a]) * scale);
      const std::int64_t high = latticeFloor((position[a] + reach - origin[a]) * scale);
      if (high < 0) query.empty = true;
      query.lo[a] = clampToLattice(low);
      query.hi[a] = clampToLattice(high);
    }
  };
  auto volume = [](const std::uint32_t lo[3], const std::uint32_t hi[3]) {
    return double(hi[0] - lo[0] + 1) * double(hi[1] - lo[1] + 1) * double(hi[2] - lo[2] + 1);
  };

  std::uint32_t place = placeBegin;
  while (place < placeEnd) {
    // Gather the group: stop when the joint box grows past 8 times the first cube.
    int size = 0;
    std::uint32_t lo[3], hi[3];
    makeQuery(place, group[0]);
    if (group[0].empty) {
      writer.finishQuery(group[0].index);
      ++place;
      continue;
    }
    for (int a = 0; a < 3; ++a) {
      lo[a] = group[0].lo[a];
      hi[a] = group[0].hi[a];
    }
    const double limit = 8.0 * volume(lo, hi);
    size = 1;
    while (size < kGroup && place + size < placeEnd) {
      Query& next = group[size];
      makeQuery(place + size, next);
      if (next.empty) break;
      std::uint32_t newLo[3], newHi[3];
      for (int a = 0; a < 3; ++a) {
        newLo[a] = std::min(lo[a], next.lo[a]);
        newHi[a] = std::max(hi[a], next.hi[a]);
      }
      if (volume(newLo, newHi) > limit) break;
      for (int a = 0; a < 3; ++a) {
        lo[a] = newLo[a];
        hi[a] = newHi[a];
      }
      ++size;
    }

    // Walk the tree with the joint box, one record (the children of a node)
    // per step, in curve order: a child that meets the box is collected if it
    // is a leaf or lies inside the box, else its own record is entered.
    runBegins.clear();
    runEnds.clear();
    for (auto& v : candidateLo) v.clear();
    for (auto& v : candidateHi) v.clear();
    int top = 0;
    auto enter = [&](std::uint32_t blockIndex) {
      const OctreeSearch::ChildBlock& block = blocks[blockIndex];
      unsigned overlap, inside;
      BoxFilter::childMasks(block, lo, hi, overlap, inside);
      const unsigned collect = overlap & (inside | BoxFilter::leafMask(block));
      // The records the walk enters next: start loading them now.
      for (unsigned descend = overlap & ~collect; descend; descend &= descend - 1) {
        const char* next = reinterpret_cast<const char*>(blocks + block.block[__builtin_ctz(descend)]);
        __builtin_prefetch(next);
        __builtin_prefetch(next + 64);
        __builtin_prefetch(next + 128);
      }
      frames[top++] = Frame{blockIndex, overlap, collect};
    };
    enter(0);
    while (top > 0) {
      Frame& frame = frames[top - 1];
      if (!frame.pending) {
        --top;
        continue;
      }
      const unsigned k = static_cast<unsigned>(__builtin_ctz(frame.pending));
      frame.pending &= frame.pending - 1;
      const OctreeSearch::ChildBlock& block = blocks[frame.block];
      if (!((frame.collect >> k) & 1u)) {
        enter(block.block[k]);
        continue;
      }
      const std::uint32_t last = (std::uint32_t(1) << (kLevels - block.level[k])) - 1;
      const std::uint32_t begin = block.begin[k], end = block.begin[k + 1];
      // Nodes reached one after the other along the curve are usually
      // contiguous places: one run, with the box around both.
      if (MergeRuns && !runEnds.empty() && runEnds.back() == begin) {
        runEnds.back() = end;
        for (int a = 0; a < 3; ++a) {
          candidateLo[a].back() = std::min(candidateLo[a].back(), block.lo[a][k]);
          candidateHi[a].back() = std::max(candidateHi[a].back(), block.lo[a][k] + last);
        }
        continue;
      }
      runBegins.push_back(begin);
      runEnds.push_back(end);
      for (int a = 0; a < 3; ++a) {
        candidateLo[a].push_back(block.lo[a][k]);
        candidateHi[a].push_back(block.lo[a][k] + last);
      }
    }

    // Each query: the collected nodes that meet its cube, then exact tests.
    // Collected nodes are in curve order, so runs of them that meet the cube
    // are usually contiguous places: scanned as one range.
    const std::size_t candidateCount = runBegins.size();
    for (int a = 0; a < 3; ++a)
      for (int pad = 0; pad < 8; ++pad) {
        candidateLo[a].push_back(1u << 30);  // meets no query box
        candidateHi[a].push_back(0);
      }
    const std::uint32_t* const boxLo[3] = {candidateLo[0].data(), candidateLo[1].data(),
                                           candidateLo[2].data()};
    const std::uint32_t* const boxHi[3] = {candidateHi[0].data(), candidateHi[1].data(),
                                           candidateHi[2].data()};
    std::size_t groupPoints = 0;  // bounds what one query of the group can list
    for (std::size_t c = 0; c < candidateCount; ++c) groupPoints += runEnds[c] - runBegins[c];
    for (int g = 0; g < size; ++g) {
      const Query& query = group[g];
      std::uint32_t runBegin = 0, runEnd = 0, found = 0;
      std::uint32_t* const out = writer.reserve(groupPoints);
      auto flush = [&] {
        if (runEnd == runBegin) return;
        found += Scan::scan(xs, ys, zs, order, runBegin, runEnd, query.x, query.y, query.z, query.radius2,
                            query.exclude, out + found);
      };
      for (std::size_t first = 0; first < candidateCount; first += 8) {
        unsigned mask = BoxFilter::mask8(boxLo, boxHi, first, query.lo, query.hi);
        while (mask) {
          const unsigned bit = static_cast<unsigned>(__builtin_ctz(mask));
          mask &= mask - 1;
          const std::uint32_t begin = runBegins[first + bit], end = runEnds[first + bit];
          if (begin != runEnd) {
            flush();
            runBegin = begin;
          }
          runEnd = end;
        }
      }
      flush();
      writer.advance(found);
      writer.finishQuery(query.index);
    }
    place += size;
  }
}

CASCADE_SEARCH_AVX2_TARGET void runOctreeChunkAvx2(const OctreeQuery& job, std::uint32_t placeBegin,
                                                    std::uint32_t placeEnd, ChunkWriter& writer) {
  job.runChunk<ScanAvx2, BoxFilterAvx2>(placeBegin, placeEnd, writer);
}

} // namespace cascade::search
