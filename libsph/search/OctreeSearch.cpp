#include "libsph/search/OctreeSearch.h"

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
  mNodes.clear();

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
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 8192), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      std::uint32_t c[3];
      for (int a = 0; a < 3; ++a)
        c[a] = clampToLattice(latticeFloor((double(points[i][a]) - mOrigin[a]) * mScale));
      mKeys[i] = mortonEncode(c[0], c[1], c[2]);
    }
  });
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

  gatherScanPositions(points, mOrder, count, mX, mY, mZ);
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

  template <typename Scan, typename BoxFilter, bool MergeRuns = true>
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
  const OctreeSearch::Node* nodes = tree.mNodes.data();
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
  std::uint32_t stack[kLevels * 8 + 16];

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

    // Walk the tree with the joint box.
    runBegins.clear();
    runEnds.clear();
    for (auto& v : candidateLo) v.clear();
    for (auto& v : candidateHi) v.clear();
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const std::uint32_t nodeIndex = stack[--top];
      const OctreeSearch::Node& node = nodes[nodeIndex];
      const std::uint32_t last = (std::uint32_t(1) << (kLevels - node.level)) - 1;
      bool overlap = true, inside = true;
      for (int a = 0; a < 3; ++a) {
        const std::uint32_t nodeLo = node.corner[a], nodeHi = node.corner[a] + last;
        overlap &= nodeLo <= hi[a] && nodeHi >= lo[a];
        inside &= nodeLo >= lo[a] && nodeHi <= hi[a];
      }
      if (!overlap) continue;
      if (inside || node.childCount == 0) {
        // Nodes reached one after the other along the curve are usually
        // contiguous places: one run, with the box around both.
        if (MergeRuns && !runEnds.empty() && runEnds.back() == node.begin) {
          runEnds.back() = node.end;
          for (int a = 0; a < 3; ++a) {
            candidateLo[a].back() = std::min(candidateLo[a].back(), node.corner[a]);
            candidateHi[a].back() = std::max(candidateHi[a].back(), node.corner[a] + last);
          }
          continue;
        }
        runBegins.push_back(node.begin);
        runEnds.push_back(node.end);
        for (int a = 0; a < 3; ++a) {
          candidateLo[a].push_back(node.corner[a]);
          candidateHi[a].push_back(node.corner[a] + last);
        }
        continue;
      }
      for (int c = node.childCount - 1; c >= 0; --c) stack[top++] = node.firstChild + c;
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
    for (int g = 0; g < size; ++g) {
      const Query& query = group[g];
      std::uint32_t runBegin = 0, runEnd = 0;
      auto flush = [&] {
        if (runEnd == runBegin) return;
        std::uint32_t* out = writer.reserve(runEnd - runBegin);
        writer.advance(Scan::scan(xs, ys, zs, order, runBegin, runEnd, query.x, query.y, query.z,
                                  query.radius2, query.exclude, out));
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
