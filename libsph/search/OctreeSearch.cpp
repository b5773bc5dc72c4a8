#include "libsph/search/OctreeSearch.h"

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

struct Bounds {
  double lo[3] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                  std::numeric_limits<double>::infinity()};
  double hi[3] = {-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
                  -std::numeric_limits<double>::infinity()};
  void add(const Vec3r& p) {
    if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z())) return;
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], double(p[a]));
      hi[a] = std::max(hi[a], double(p[a]));
    }
  }
  void join(const Bounds& other) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], other.lo[a]);
      hi[a] = std::max(hi[a], other.hi[a]);
    }
  }
  bool empty() const { return !(lo[0] <= hi[0]); }
};

/// floor(t) limited to [-1, 2^21]; NaN gives -1. Monotone in t.
inline std::int64_t latticeFloor(double t) {
  const double c = std::floor(t);
  if (!(c >= -1.0)) return -1;
  if (c > double(kMaxLattice + 1)) return kMaxLattice + 1;
  return static_cast<std::int64_t>(c);
}

inline std::uint32_t clampLattice(std::int64_t c) {
  return static_cast<std::uint32_t>(std::clamp<std::int64_t>(c, 0, kMaxLattice));
}

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

} // namespace

void OctreeSearch::build(const Vec3r* points, std::size_t count, Real maxSupportRadius) {
  if (count >= std::size_t(kNoIndex))
    throw std::length_error("octree neighbour search: too many points (" + std::to_string(count) + ")");
  mPoints = points;
  mCount = count;
  mRadius = maxSupportRadius;
  mNodes.clear();

  const Bounds bounds = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, count, 4096), Bounds{},
      [&](const tbb::blocked_range<std::size_t>& range, Bounds local) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) local.add(points[i]);
        return local;
      },
      [](Bounds a, const Bounds& b) {
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
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 8192), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      std::uint32_t c[3];
      for (int a = 0; a < 3; ++a)
        c[a] = clampLattice(latticeFloor((double(points[i][a]) - mOrigin[a]) * mScale));
      mKeys[i] = mortonEncode(c[0], c[1], c[2]);
    }
  });
  radixSortPairs(mKeys, mOrder, 3 * kLevels, mKeyScratch, mIndexScratch);

  mX.resize(count + kScanPadding);
  mY.resize(count + kScanPadding);
  mZ.resize(count + kScanPadding);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 8192), [&](const auto& range) {
    for (std::size_t k = range.begin(); k != range.end(); ++k) {
      const Vec3r& p = points[mOrder[k]];
      mX[k] = p.x();
      mY[k] = p.y();
      mZ[k] = p.z();
    }
  });
  for (std::size_t k = count; k < count + kScanPadding; ++k)
    mX[k] = mY[k] = mZ[k] = std::numeric_limits<Real>::quiet_NaN();
  mOrder.resize(count + kScanPadding, kNoIndex);  // read (never reported) by the vector scans
  if (count == 0) return;

  // The tree. The root is the cube of the common prefix of all codes (the
  // levels above it would each have a single child).
  Node root{};
  const int rootLevel = commonLevel(mKeys.front(), mKeys.back());
  cubeCorner(mKeys.front(), rootLevel, root.corner);
  root.level = static_cast<std::uint8_t>(rootLevel);
  root.begin = 0;
  root.end = static_cast<std::uint32_t>(count);
  mNodes.push_back(root);

  // Top of the tree breadth first until the nodes are small enough to be
  // built by one task each, then those subtrees in parallel, then spliced in.
  std::vector<std::uint32_t> frontier{0}, deferred;
  auto split = [&](std::uint32_t nodeIndex, std::vector<Node>& nodes, std::vector<std::uint32_t>* next) {
    Node node = nodes[nodeIndex];
    const std::uint32_t size = node.end - node.begin;
    if (size <= mLeafSize || node.level >= kLevels) return;
    // Skip the chain of one-child cubes: split at the level where the codes differ.
    const int level = std::max<int>(node.level, commonLevel(mKeys[node.begin], mKeys[node.end - 1]));
    if (level >= kLevels) return;  // coincident lattice cells: a leaf of the finest level
    node.level = static_cast<std::uint8_t>(level);
    cubeCorner(mKeys[node.begin], level, node.corner);
    node.firstChild = static_cast<std::uint32_t>(nodes.size());
    node.childCount = 0;
    std::uint32_t start = node.begin;
    while (start < node.end) {
      const unsigned digit = childDigit(mKeys[start], level);
      std::uint32_t stop;
      if (node.end - start <= 16) {
        stop = start + 1;
        while (stop < node.end && childDigit(mKeys[stop], level) == digit) ++stop;
      } else {
        stop = static_cast<std::uint32_t>(
            std::partition_point(mKeys.begin() + start, mKeys.begin() + node.end,
                                 [&](std::uint64_t key) { return childDigit(key, level) <= digit; }) -
            mKeys.begin());
      }
      Node child{};
      child.level = static_cast<std::uint8_t>(level + 1);
      cubeCorner(mKeys[start], level + 1, child.corner);
      child.begin = start;
      child.end = stop;
      nodes.push_back(child);
      ++node.childCount;
      start = stop;
    }
    nodes[nodeIndex] = node;
    if (next)
      for (std::uint32_t c = 0; c < node.childCount; ++c) next->push_back(node.firstChild + c);
  };
  while (!frontier.empty()) {
    std::vector<std::uint32_t> next;
    for (const std::uint32_t nodeIndex : frontier) {
      if (mNodes[nodeIndex].end - mNodes[nodeIndex].begin <= kSerialBuild)
        deferred.push_back(nodeIndex);
      else
        split(nodeIndex, mNodes, &next);
    }
    frontier.swap(next);
  }
  std::vector<std::vector<Node>> subtrees(deferred.size());
  tbb::parallel_for(std::size_t(0), deferred.size(), [&](std::size_t d) {
    std::vector<Node>& nodes = subtrees[d];
    nodes.push_back(mNodes[deferred[d]]);
    std::vector<std::uint32_t> stack{0};
    while (!stack.empty()) {
      const std::uint32_t nodeIndex = stack.back();
      stack.pop_back();
      split(nodeIndex, nodes, nullptr);
      const Node& node = nodes[nodeIndex];
      for (std::uint32_t c = 0; c < node.childCount; ++c) stack.push_back(node.firstChild + c);
    }
  });
  std::size_t total = mNodes.size();
  std::vector<std::size_t> base(deferred.size());
  for (std::size_t d = 0; d < deferred.size(); ++d) {
    base[d] = total;
    total += subtrees[d].size() - 1;
  }
  if (total >= std::size_t(kNoIndex)) throw std::length_error("octree: too many nodes");
  mNodes.resize(total);
  tbb::parallel_for(std::size_t(0), deferred.size(), [&](std::size_t d) {
    // Subtree node i >= 1 goes to base + i - 1; its root replaces the deferred node.
    const auto relocate = [&](Node node) {
      if (node.childCount) node.firstChild = static_cast<std::uint32_t>(base[d] + node.firstChild - 1);
      return node;
    };
    const std::vector<Node>& nodes = subtrees[d];
    mNodes[deferred[d]] = relocate(nodes[0]);
    for (std::size_t i = 1; i < nodes.size(); ++i) mNodes[base[d] + i - 1] = relocate(nodes[i]);
  });
}

std::size_t OctreeSearch::largestLeaf() const {
  std::size_t largest = 0;
  for (const Node& node : mNodes)
    if (!node.childCount) largest = std::max<std::size_t>(largest, node.end - node.begin);
  return largest;
}

int OctreeSearch::depth() const {
  int deepest = 0;
  for (const Node& node : mNodes) deepest = std::max<int>(deepest, node.level);
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

  template <typename Scan>
  void runChunk(std::uint32_t placeBegin, std::uint32_t placeEnd, ChunkWriter& writer) const;
};

CASCADE_SEARCH_AVX2_TARGET void runOctreeChunkAvx2(const OctreeQuery& job, std::uint32_t placeBegin,
                                                    std::uint32_t placeEnd, ChunkWriter& writer);

void OctreeSearch::query(const Vec3r* queries, std::size_t count, const Real* supportRadii,
                         bool excludeSelf, NeighborLists& out) const {
  if (count == 0 || mCount == 0) {
    out.offsets.assign(count + 1, 0u);
    out.indices.clear();
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
          c[a] = clampLattice(latticeFloor((double(queries[i][a]) - mOrigin[a]) * mScale));
        keys[i] = mortonEncode(c[0], c[1], c[2]);
      }
    });
    radixSortPairs(keys, ownOrder, 3 * kLevels, keyScratch, indexScratch);
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
                    job.runChunk<ScanBaseline>(placeBegin, placeEnd, writer);
                });
}

template <typename Scan>
void OctreeQuery::runChunk(std::uint32_t placeBegin, std::uint32_t placeEnd, ChunkWriter& writer) const {
    const Real* xs = tree.mX.data();
    const Real* ys = tree.mY.data();
    const Real* zs = tree.mZ.data();
    const std::uint32_t* order = tree.mOrder.data();
    const OctreeSearch::Node* nodes = tree.mNodes.data();
    const double* origin = tree.mOrigin;
    const double scale = tree.mScale;
    std::uint32_t stack[kLevels * 8 + 16];
    for (std::uint32_t s = placeBegin; s < placeEnd; ++s) {
      const std::uint32_t q = queryOrder[s];
      Real qx, qy, qz;
      if (self) {
        qx = xs[s];
        qy = ys[s];
        qz = zs[s];
      } else {
        qx = queries[q].x();
        qy = queries[q].y();
        qz = queries[q].z();
      }
      const Real radius = radii ? radii[q] : tree.mRadius;
      const Real radius2 = radius * radius;
      const std::uint32_t exclude = excludeSelf ? q : kNoIndex;
      // The query cube of edge 2 x radius (SEED 2.1: 2 kappa h_i), on the lattice.
      const double reach = std::fabs(double(radius)) * (1.0 + kRangeMargin) + kRangeSlack;
      const double qpos[3] = {double(qx), double(qy), double(qz)};
      std::uint32_t lo[3], hi[3];
      bool empty = !(reach >= 0);
      for (int a = 0; a < 3 && !empty; ++a) {
        const std::int64_t low = latticeFloor((qpos[a] - reach - origin[a]) * scale);
        const std::int64_t high = latticeFloor((qpos[a] + reach - origin[a]) * scale);
        if (high < 0) empty = true;
        lo[a] = clampLattice(low);
        hi[a] = clampLattice(high);
      }
      if (!empty) {
        int top = 0;
        stack[top++] = 0;
        while (top > 0) {
          const OctreeSearch::Node& node = nodes[stack[--top]];
          const std::uint32_t last = (std::uint32_t(1) << (kLevels - node.level)) - 1;
          bool overlap = true, inside = true;
          for (int a = 0; a < 3; ++a) {
            const std::uint32_t nodeLo = node.corner[a], nodeHi = node.corner[a] + last;
            overlap &= nodeLo <= hi[a] && nodeHi >= lo[a];
            inside &= nodeLo >= lo[a] && nodeHi <= hi[a];
          }
          if (!overlap) continue;
          if (inside || node.childCount == 0) {
            std::uint32_t* outPtr = writer.reserve(node.end - node.begin);
            writer.advance(Scan::scan(xs, ys, zs, order, node.begin, node.end, qx, qy, qz, radius2,
                                     exclude, outPtr));
            continue;
          }
          for (int c = node.childCount - 1; c >= 0; --c) stack[top++] = node.firstChild + c;
        }
      }
      writer.finishQuery(q);
    }
}

CASCADE_SEARCH_AVX2_TARGET void runOctreeChunkAvx2(const OctreeQuery& job, std::uint32_t placeBegin,
                                                    std::uint32_t placeEnd, ChunkWriter& writer) {
  job.runChunk<ScanAvx2>(placeBegin, placeEnd, writer);
}

} // namespace cascade::search
