#include "libsph/search/UniformGridSearch.h"

#include "libsph/search/CellKeys.h"
#include "libsph/search/Lattice.h"
#include "libsph/search/MortonCode.h"
#include "libsph/search/ListAssembly.h"
#include "libsph/search/RadixSort.h"
#include "libsph/search/ScanRange.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>

namespace cascade::search {

namespace {

constexpr std::int64_t kMaxCell = kMortonMaxCoord;
constexpr std::uint32_t kNoIndex = std::numeric_limits<std::uint32_t>::max();
/// Enlarges the cell edge over the build radius so that rounding never moves a
/// neighbour (within the build radius) outside the 27 cells around a query.
constexpr double kCellMargin = 1.0 / 1024.0;
/// Enlarges a query's cell-range bounds over its radius: covers the rounding of
/// the float squared distance (a few ulp) and of the bounds themselves.
constexpr double kRangeMargin = 1e-5;
constexpr double kRangeSlack = 1e-20;
constexpr std::size_t kPad = kScanPadding;

inline std::uint64_t hashKey(std::uint64_t key) { return key * 0x9E3779B97F4A7C15ULL; }

/// Places [begin, end) of a cell or of adjacent cells.
using CellRange = UniformGridSearch::PlaceRange;

} // namespace

void UniformGridSearch::computeFrame(const Vec3r* points, std::size_t count, Real maxSupportRadius) {
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
  double cellSize = double(maxSupportRadius) * (1.0 + kCellMargin);
  if (!(cellSize > 0) || !std::isfinite(cellSize)) {
    double extent = 0;
    if (!bounds.empty())
      for (int a = 0; a < 3; ++a) extent = std::max(extent, bounds.hi[a] - bounds.lo[a]);
    cellSize = extent > 0 && std::isfinite(extent) ? extent / 1024.0 : 1.0;
  }
  mCellSize = cellSize;
  mInvCellSize = 1.0 / cellSize;
  for (int a = 0; a < 3; ++a) {
    // The origin snaps to the global lattice of cells so that it rarely changes
    // between builds (the incremental rebuild needs the same cells).
    mOrigin[a] = mIds ? mAnchor[a] : bounds.empty() ? 0.0 : cellSize * std::floor(bounds.lo[a] * mInvCellSize);
    if (!std::isfinite(mOrigin[a])) mOrigin[a] = 0;
    mMaxCell[a] = bounds.empty() ? 0 : clampToLattice(latticeFloor((bounds.hi[a] - mOrigin[a]) * mInvCellSize));
  }
  const double reach = std::fabs(double(maxSupportRadius)) * (1.0 + kRangeMargin) + kRangeSlack;
  mSelfStencilOk = reach < cellSize * (1.0 - 1e-9);
  for (int a = 0; a < 3 && !bounds.empty(); ++a)
    if (latticeFloor((bounds.hi[a] - mOrigin[a]) * mInvCellSize) > kMaxCell) mSelfStencilOk = false;
}

void UniformGridSearch::build(const Vec3r* points, std::size_t count, Real maxSupportRadius) {
  if (count >= std::size_t(kNoIndex))
    throw std::length_error("grid neighbour search: too many points (" + std::to_string(count) + ")");
  const double oldOrigin[3] = {mOrigin[0], mOrigin[1], mOrigin[2]};
  const double oldCellSize = mCellSize;
  computeFrame(points, count, maxSupportRadius);
  const bool sameFrame = mHaveFrame && oldCellSize == mCellSize && oldOrigin[0] == mOrigin[0] &&
                         oldOrigin[1] == mOrigin[1] && oldOrigin[2] == mOrigin[2];
  sortPoints(points, count, sameFrame);
  mPoints = points;
  mCount = count;
  mRadius = maxSupportRadius;
  mHaveFrame = true;

  // Positions in curve order, padded so that vector loads may read past a range.
  gatherScanPositions(points, mOrder.data(), count, mX, mY, mZ);
  buildCells();
  // Padding read (never reported) by the vector scans.
  mOrder.resize(count + kPad, kNoIndex);
}

void UniformGridSearch::sortPoints(const Vec3r* points, std::size_t count, bool sameFrame) {
  mOrder.resize(mKeys.size());  // drop the scan padding
  // Morton key of every point, by point index.
  std::vector<std::uint64_t>& pointKey = mKeyScratch2;
  pointKey.resize(count);
  cellKeys(points, count, mOrigin, mInvCellSize, pointKey.data());
  const int keyBits =
      3 * bitWidth(std::max({std::uint64_t(mMaxCell[0]), std::uint64_t(mMaxCell[1]),
                             std::uint64_t(mMaxCell[2])}));

  mLastIncremental = false;
  mLastMoved = count;
  if (mIncremental && !mIds && sameFrame && mCount == count && mKeys.size() == count && count > 0) {
    // Base order: the previous curve order, or the identity when the caller has
    // reordered its points along it since (Particles::permute(zOrder())).
    struct Moved {
      std::size_t previous = 0, identity = 0;
    };
    const Moved moved = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, count, 8192), Moved{},
        [&](const tbb::blocked_range<std::size_t>& range, Moved local) {
          for (std::size_t k = range.begin(); k != range.end(); ++k) {
            local.previous += pointKey[mOrder[k]] != mKeys[k];
            local.identity += pointKey[k] != mKeys[k];
          }
          return local;
        },
        [](Moved a, const Moved& b) {
          a.previous += b.previous;
          a.identity += b.identity;
          return a;
        });
    const bool useIdentity = moved.identity < moved.previous;
    const std::size_t movedCount = useIdentity ? moved.identity : moved.previous;
    if (movedCount <= count / 4) {
      mLastIncremental = true;
      mLastMoved = movedCount;
      if (useIdentity) std::iota(mOrder.begin(), mOrder.end(), 0u);
      // Points whose cell is unchanged keep their (sorted) places; the moved
      // ones are sorted on their own and merged in.
      std::vector<std::uint64_t> movedKeys;
      std::vector<std::uint32_t> movedIndex;
      movedKeys.reserve(movedCount);
      movedIndex.reserve(movedCount);
      std::vector<std::uint64_t>& keptKeys = mKeyScratch;
      std::vector<std::uint32_t>& keptIndex = mIndexScratch;
      keptKeys.resize(count);
      keptIndex.resize(count);
      std::size_t kept = 0;
      for (std::size_t k = 0; k < count; ++k) {
        const std::uint32_t index = mOrder[k];
        const std::uint64_t key = pointKey[index];
        if (key == mKeys[k]) {
          keptKeys[kept] = key;
          keptIndex[kept++] = index;
        } else {
          movedKeys.push_back(key);
          movedIndex.push_back(index);
        }
      }
      std::vector<std::uint64_t> keyScratch;
      std::vector<std::uint32_t> indexScratch;
      radixSortPairs(movedKeys, movedIndex, keyBits, keyScratch, indexScratch);
      // Canonical order, as a full rebuild gives it: by cell, then by point
      // index (kept points already are; the moved ones of one cell may come
      // from several old cells). The order, and so the neighbour lists, then
      // depend only on the current positions, not on the build history.
      const std::size_t moves = movedKeys.size();
      for (std::size_t first = 0; first < moves;) {
        std::size_t last = first + 1;
        while (last < moves && movedKeys[last] == movedKeys[first]) ++last;
        if (last - first > 1) std::sort(movedIndex.begin() + first, movedIndex.begin() + last);
        first = last;
      }
      std::size_t a = 0, b = 0, k = 0;
      while (a < kept && b < moves) {
        if (movedKeys[b] < keptKeys[a] || (movedKeys[b] == keptKeys[a] && movedIndex[b] < keptIndex[a])) {
          mKeys[k] = movedKeys[b];
          mOrder[k++] = movedIndex[b++];
        } else {
          mKeys[k] = keptKeys[a];
          mOrder[k++] = keptIndex[a++];
        }
      }
      for (; a < kept; ++a, ++k) {
        mKeys[k] = keptKeys[a];
        mOrder[k] = keptIndex[a];
      }
      for (; b < moves; ++b, ++k) {
        mKeys[k] = movedKeys[b];
        mOrder[k] = movedIndex[b];
      }
      return;
    }
  }
  mOrder.resize(count);
  if (mIds) {
    // Canonical: the points in id order first, then a stable radix sort by cell key.
    std::vector<std::uint64_t>& ids = mKeys;
    ids.resize(count);
    for (std::size_t i = 0; i < count; ++i) ids[i] = mIds[i];
    std::iota(mOrder.begin(), mOrder.end(), 0u);
    radixSortPairs(ids, mOrder, 32, mKeyScratch, mIndexScratch);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 8192), [&](const auto& range) {
      for (std::size_t k = range.begin(); k != range.end(); ++k) mKeys[k] = pointKey[mOrder[k]];
    });
    radixSortPairs(mKeys, mOrder, keyBits, mKeyScratch, mIndexScratch);
    return;
  }
  // Full rebuild: radix sort of (key, index) in index order.
  mKeys.assign(pointKey.begin(), pointKey.end());
  std::iota(mOrder.begin(), mOrder.end(), 0u);
  radixSortPairs(mKeys, mOrder, keyBits, mKeyScratch, mIndexScratch);
}

bool UniformGridSearch::setCanonicalOrder(const ParticleId* ids, const Vec3r& anchor) {
  mIds = ids;
  for (int a = 0; a < 3; ++a) mAnchor[a] = double(anchor[a]);
  return true;
}

void UniformGridSearch::buildCells() {
  const std::size_t n = mKeys.size();
  mCellStart.clear();
  mCellKey.clear();
  for (std::size_t k = 0; k < n; ++k) {
    if (k == 0 || mKeys[k] != mKeys[k - 1]) {
      mCellStart.push_back(static_cast<std::uint32_t>(k));
      mCellKey.push_back(mKeys[k]);
    }
  }
  mCellStart.push_back(static_cast<std::uint32_t>(n));
  const std::size_t cells = mCellKey.size();
  const double boxCells = double(mMaxCell[0] + 1) * double(mMaxCell[1] + 1) * double(mMaxCell[2] + 1);
  mUseDense = boxCells <= std::max(8.0 * double(n), 65536.0);
  if (mUseDense) {
    mHash.clear();
    mDense.assign(static_cast<std::size_t>(boxCells), 0u);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cells, 4096), [&](const auto& range) {
      for (std::size_t c = range.begin(); c != range.end(); ++c) {
        std::uint32_t x, y, z;
        mortonDecode(mCellKey[c], x, y, z);
        mDense[x + std::size_t(mMaxCell[0] + 1) * (y + std::size_t(mMaxCell[1] + 1) * z)] =
            static_cast<std::uint32_t>(c + 1);
      }
    });
    return;
  }
  mDense.clear();
  std::size_t capacity = 16;
  while (capacity < 2 * cells) capacity *= 2;
  mHash.assign(capacity, HashEntry{0, 0});
  mHashMask = capacity - 1;
  for (std::size_t c = 0; c < cells; ++c) {
    std::uint64_t slot = (hashKey(mCellKey[c]) >> 20) & mHashMask;
    while (mHash[slot].cell != 0) slot = (slot + 1) & mHashMask;
    mHash[slot] = HashEntry{mCellKey[c], static_cast<std::uint32_t>(c + 1)};
  }
}

std::int64_t UniformGridSearch::findCell(std::uint32_t x, std::uint32_t y, std::uint32_t z) const {
  if (mUseDense)
    return std::int64_t(mDense[x + std::size_t(mMaxCell[0] + 1) * (y + std::size_t(mMaxCell[1] + 1) * z)]) - 1;
  const std::uint64_t key = mortonEncode(x, y, z);
  std::uint64_t slot = (hashKey(key) >> 20) & mHashMask;
  for (;;) {
    const HashEntry& entry = mHash[slot];
    if (entry.cell == 0) return -1;
    if (entry.key == key) return std::int64_t(entry.cell) - 1;
    slot = (slot + 1) & mHashMask;
  }
}

std::vector<std::size_t> UniformGridSearch::zOrder() const {
  return std::vector<std::size_t>(mOrder.begin(), mOrder.begin() + mCount);
}

/// One query() call: the queries grouped by cell, processed in parallel chunks.
struct GridQuery {
  const UniformGridSearch& grid;
  const Vec3r* queries;
  const Real* radii;
  bool excludeSelf;
  bool self;  ///< the queries are the indexed points: their places are the grid's
  const std::uint32_t* queryOrder;     ///< query index per query place
  const std::uint32_t* groupStart;     ///< first query place of each group, plus the end
  const std::uint64_t* groupKey;       ///< Morton key of each group's (clamped) cell

  struct Stencil {
    std::array<CellRange, 27> ranges;   ///< per cell offset, empty if no such cell
    std::array<CellRange, 27> merged;   ///< non-empty ranges, adjacent ones joined
    int mergedCount = 0;
    std::uint32_t candidates = 0;
  };

  void makeStencil(std::uint64_t key, Stencil& stencil) const {
    std::uint32_t c[3];
    mortonDecode(key, c[0], c[1], c[2]);
    int slot = 0;
    std::array<CellRange, 27> sorted;
    int nonEmpty = 0;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx, ++slot) {
          CellRange range{0, 0};
          const std::int64_t x = std::int64_t(c[0]) + dx, y = std::int64_t(c[1]) + dy,
                             z = std::int64_t(c[2]) + dz;
          if (x >= 0 && y >= 0 && z >= 0 && x <= grid.mMaxCell[0] && y <= grid.mMaxCell[1] &&
              z <= grid.mMaxCell[2]) {
            const std::int64_t cell =
                grid.findCell(std::uint32_t(x), std::uint32_t(y), std::uint32_t(z));
            if (cell >= 0) range = {grid.mCellStart[cell], grid.mCellStart[cell + 1]};
          }
          stencil.ranges[slot] = range;
          if (range.end > range.begin) sorted[nonEmpty++] = range;
        }
    std::sort(sorted.begin(), sorted.begin() + nonEmpty,
              [](const CellRange& a, const CellRange& b) { return a.begin < b.begin; });
    stencil.mergedCount = 0;
    stencil.candidates = 0;
    for (int i = 0; i < nonEmpty; ++i) {
      stencil.candidates += sorted[i].end - sorted[i].begin;
      if (stencil.mergedCount > 0 && stencil.merged[stencil.mergedCount - 1].end == sorted[i].begin)
        stencil.merged[stencil.mergedCount - 1].end = sorted[i].end;
      else
        stencil.merged[stencil.mergedCount++] = sorted[i];
    }
  }

  /// Scans every occupied cell in the box [lo, hi] of (clamped) cell coordinates.
  template <typename Emit>
  void scanBox(const std::uint32_t lo[3], const std::uint32_t hi[3], Emit&& emit) const {
    const double boxCells = double(hi[0] - lo[0] + 1) * double(hi[1] - lo[1] + 1) *
                            double(hi[2] - lo[2] + 1);
    if (boxCells > 4.0 * double(grid.cellCount())) {
      for (std::size_t cell = 0; cell < grid.cellCount(); ++cell) {
        std::uint32_t c[3];
        mortonDecode(grid.mCellKey[cell], c[0], c[1], c[2]);
        if (c[0] >= lo[0] && c[0] <= hi[0] && c[1] >= lo[1] && c[1] <= hi[1] && c[2] >= lo[2] &&
            c[2] <= hi[2])
          emit(grid.mCellStart[cell], grid.mCellStart[cell + 1]);
      }
      return;
    }
    for (std::uint32_t z = lo[2]; z <= hi[2]; ++z)
      for (std::uint32_t y = lo[1]; y <= hi[1]; ++y)
        for (std::uint32_t x = lo[0]; x <= hi[0]; ++x) {
          const std::int64_t cell = grid.findCell(x, y, z);
          if (cell >= 0) emit(grid.mCellStart[cell], grid.mCellStart[cell + 1]);
        }
  }

  /// Scans every occupied cell of the box [lo, hi] of unclamped cell coordinates.
  template <typename Emit>
  void scanBoxOf(const std::int64_t lo[3], const std::int64_t hi[3], Emit&& emit) const {
    std::uint32_t boxLo[3], boxHi[3];
    for (int a = 0; a < 3; ++a) {
      boxLo[a] = clampToLattice(lo[a]);
      boxHi[a] = std::min(clampToLattice(hi[a]), grid.mMaxCell[a]);
      if (boxLo[a] > boxHi[a] || hi[a] < 0) return;
    }
    scanBox(boxLo, boxHi, emit);
  }

  /// Every occupied cell within `radius` of q (the general path's box).
  template <typename Emit>
  void forEachCellAround(const Vec3r& q, Real radius, Emit&& emit) const {
    const double reach = std::fabs(double(radius)) * (1.0 + kRangeMargin) + kRangeSlack;
    if (!(reach >= 0)) return;
    std::int64_t lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = latticeFloor((double(q[a]) - reach - grid.mOrigin[a]) * grid.mInvCellSize);
      hi[a] = latticeFloor((double(q[a]) + reach - grid.mOrigin[a]) * grid.mInvCellSize);
    }
    scanBoxOf(lo, hi, emit);
  }

  /// A self query with the build radius, the queries of group (cell) g: the 27
  /// cells hold every neighbour. The points of the cells within the radius of
  /// the box that bounds the cell's queries are first gathered into one packed
  /// run (in place order, so the lists keep the order of a scan of the cells),
  /// then every query scans that run, two at a time (the points loaded once for
  /// both). The box test keeps every point within the radius of some query: its
  /// distance is at most the query's, and the reach allows for round-off.
  template <typename Scan>
  void runCellCompact(std::size_t g, Stencil& stencil, std::vector<Real>& nearX, std::vector<Real>& nearY,
                      std::vector<Real>& nearZ, std::vector<std::uint32_t>& nearIndex, ChunkWriter& writer) const {
    const Real* xs = grid.mX.data();
    const Real* ys = grid.mY.data();
    const Real* zs = grid.mZ.data();
    const std::uint32_t first = groupStart[g], last = groupStart[g + 1];
    makeStencil(groupKey[g], stencil);
    Real lo[3] = {std::numeric_limits<Real>::infinity(), std::numeric_limits<Real>::infinity(),
                  std::numeric_limits<Real>::infinity()};
    Real hi[3] = {-lo[0], -lo[1], -lo[2]};
    for (std::uint32_t s = first; s < last; ++s) {
      // (NaN coordinates fail both tests: such a query has no neighbours.)
      if (xs[s] < lo[0]) lo[0] = xs[s];
      if (xs[s] > hi[0]) hi[0] = xs[s];
      if (ys[s] < lo[1]) lo[1] = ys[s];
      if (ys[s] > hi[1]) hi[1] = ys[s];
      if (zs[s] < lo[2]) lo[2] = zs[s];
      if (zs[s] > hi[2]) hi[2] = zs[s];
    }
    const Real radius2 = grid.mRadius * grid.mRadius;
    const Real reach2 = radius2 * Real(1 + 1e-5) + std::numeric_limits<Real>::min();
    const std::size_t room = std::size_t(stencil.candidates) + 2 * kScanOverwrite;
    if (nearIndex.size() < room) {
      nearX.resize(room);
      nearY.resize(room);
      nearZ.resize(room);
      nearIndex.resize(room);
    }
    std::uint32_t near = 0;
    for (int r = 0; r < stencil.mergedCount; ++r)
      near = Scan::gatherNear(xs, ys, zs, grid.mOrder.data(), stencil.merged[r].begin, stencil.merged[r].end,
                              lo, hi, reach2, nearX.data(), nearY.data(), nearZ.data(), nearIndex.data(), near);
    const Real *bx = nearX.data(), *by = nearY.data(), *bz = nearZ.data();
    const std::uint32_t* bi = nearIndex.data();
    for (std::uint32_t s = first; s < last; ++s) {
      const std::uint32_t q = queryOrder[s];
      const std::uint32_t exclude = excludeSelf ? q : kNoIndex;
      if (s + 1 < last) {
        const std::uint32_t q2 = queryOrder[s + 1];
        const Real a[3] = {xs[s], ys[s], zs[s]}, b[3] = {xs[s + 1], ys[s + 1], zs[s + 1]};
        std::uint32_t* out = writer.reserve(2 * (std::size_t(near) + kScanOverwrite));
        std::uint32_t* out2 = out + near + kScanOverwrite;
        std::uint32_t found = 0, found2 = 0;
        Scan::scanPair(bx, by, bz, bi, 0, near, a, b, radius2, exclude, excludeSelf ? q2 : kNoIndex, out, out2,
                       found, found2);
        writer.advance(found);
        writer.finishQuery(q);
        Scan::moveDown(out + found, out2, found2);
        writer.advance(found2);
        writer.finishQuery(q2);
        ++s;
        continue;
      }
      std::uint32_t* out = writer.reserve(std::size_t(near) + kScanOverwrite);
      writer.advance(Scan::scan(bx, by, bz, bi, 0, near, xs[s], ys[s], zs[s], radius2, exclude, out));
      writer.finishQuery(q);
    }
  }

  /// Processes the query places of groups [groupBegin, groupEnd) into buffer;
  /// writes each query's neighbour count to counts[query index].
  template <typename Scan>
  void runChunk(std::size_t groupBegin, std::size_t groupEnd, ChunkWriter& writer) const {
    Stencil stencil;
    const Real* xs = grid.mX.data();
    const Real* ys = grid.mY.data();
    const Real* zs = grid.mZ.data();
    const std::uint32_t* order = grid.mOrder.data();
    const bool alwaysStencil = self && !radii && grid.mSelfStencilOk;
    std::vector<Real> nearX, nearY, nearZ;
    std::vector<std::uint32_t> nearIndex;
    for (std::size_t g = groupBegin; g < groupEnd; ++g) {
      if (alwaysStencil) {
        runCellCompact<Scan>(g, stencil, nearX, nearY, nearZ, nearIndex, writer);
        continue;
      }
      std::uint32_t c[3];
      mortonDecode(groupKey[g], c[0], c[1], c[2]);
      bool haveStencil = false;
      for (std::uint32_t s = groupStart[g]; s < groupStart[g + 1]; ++s) {
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
        const Real radius = radii ? radii[q] : grid.mRadius;
        const Real radius2 = radius * radius;
        const std::uint32_t exclude = excludeSelf ? q : kNoIndex;
        const double reach = std::fabs(double(radius)) * (1.0 + kRangeMargin) + kRangeSlack;
        const double qpos[3] = {double(qx), double(qy), double(qz)};
        std::int64_t lo[3], hi[3], own[3];
        bool empty = false, inStencil = true;
        for (int a = 0; a < 3; ++a) {
          lo[a] = latticeFloor((qpos[a] - reach - grid.mOrigin[a]) * grid.mInvCellSize);
          hi[a] = latticeFloor((qpos[a] + reach - grid.mOrigin[a]) * grid.mInvCellSize);
          own[a] = latticeFloor((qpos[a] - grid.mOrigin[a]) * grid.mInvCellSize);
          if (hi[a] < 0 || !(reach >= 0)) empty = true;
          if (own[a] != std::int64_t(c[a]) || lo[a] < own[a] - 1 || hi[a] > own[a] + 1)
            inStencil = false;
        }
        std::uint32_t found = 0;
        if (!empty && inStencil) {
          if (!haveStencil) {
            makeStencil(groupKey[g], stencil);
            haveStencil = true;
          }
          std::uint32_t* out = writer.reserve(stencil.candidates);
          const bool full = lo[0] < own[0] && lo[1] < own[1] && lo[2] < own[2] && hi[0] > own[0] &&
                            hi[1] > own[1] && hi[2] > own[2];
          if (full) {
            for (int r = 0; r < stencil.mergedCount; ++r)
              found += Scan::scan(xs, ys, zs, order, stencil.merged[r].begin, stencil.merged[r].end,
                                 qx, qy, qz, radius2, exclude, out + found);
          } else {
            int slot = 0;
            for (int dz = -1; dz <= 1; ++dz)
              for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx, ++slot) {
                  if (own[0] + dx < lo[0] || own[0] + dx > hi[0] || own[1] + dy < lo[1] ||
                      own[1] + dy > hi[1] || own[2] + dz < lo[2] || own[2] + dz > hi[2])
                    continue;
                  const CellRange& range = stencil.ranges[slot];
                  if (range.end > range.begin)
                    found += Scan::scan(xs, ys, zs, order, range.begin, range.end, qx, qy, qz,
                                       radius2, exclude, out + found);
                }
          }
        } else if (!empty) {
          scanBoxOf(lo, hi, [&](std::uint32_t begin, std::uint32_t end) {
            std::uint32_t* out = writer.reserve(end - begin);
            writer.advance(Scan::scan(xs, ys, zs, order, begin, end, qx, qy, qz, radius2, exclude, out));
          });
        }
        writer.advance(found);
        writer.finishQuery(q);
      }
    }
  }
};

CASCADE_SEARCH_AVX2_TARGET void runGridChunkAvx2(const GridQuery& job, std::size_t groupBegin,
                                                  std::size_t groupEnd, ChunkWriter& writer) {
  job.runChunk<ScanAvx2>(groupBegin, groupEnd, writer);
}

CASCADE_SEARCH_AVX512_TARGET void runGridChunkAvx512(const GridQuery& job, std::size_t groupBegin,
                                                      std::size_t groupEnd, ChunkWriter& writer) {
  job.runChunk<ScanAvx512>(groupBegin, groupEnd, writer);
}

/// The queries of one call grouped by cell in curve order, and cut into chunks
/// of whole groups with about the same number of queries.
struct UniformGridSearch::QueryGroups {
  bool self = false;
  std::vector<std::uint32_t> ownOrder, ownGroupStart;
  std::vector<std::uint64_t> ownGroupKey;
  const std::uint32_t* queryOrder = nullptr;
  const std::uint32_t* groupStart = nullptr;
  const std::uint64_t* groupKey = nullptr;
  std::size_t groups = 0;
  std::vector<std::size_t> chunkGroup;
  std::vector<std::uint32_t> chunkStart;
};

void UniformGridSearch::groupQueries(const Vec3r* queries, std::size_t count, QueryGroups& out) const {
  if (count >= std::size_t(kNoIndex))
    throw std::length_error("grid neighbour search: too many queries (" + std::to_string(count) + ")");
  out.self = queries == mPoints && count == mCount;
  if (out.self) {
    out.queryOrder = mOrder.data();
    out.groupStart = mCellStart.data();
    out.groupKey = mCellKey.data();
    out.groups = mCellKey.size();
  } else {
    std::vector<std::uint64_t> keys(count), keyScratch;
    std::vector<std::uint32_t> indexScratch;
    out.ownOrder.resize(count);
    std::iota(out.ownOrder.begin(), out.ownOrder.end(), 0u);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 8192), [&](const auto& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        std::uint32_t c[3];
        // Queries outside the occupied box group with its border cells (they
        // take the general path: their own cell is not the group's).
        for (int a = 0; a < 3; ++a)
          c[a] = std::min(clampToLattice(latticeFloor((double(queries[i][a]) - mOrigin[a]) * mInvCellSize)),
                          mMaxCell[a]);
        keys[i] = mortonEncode(c[0], c[1], c[2]);
      }
    });
    const int keyBits = 3 * bitWidth(std::max({std::uint64_t(mMaxCell[0]), std::uint64_t(mMaxCell[1]),
                                               std::uint64_t(mMaxCell[2])}));
    radixSortPairs(keys, out.ownOrder, keyBits, keyScratch, indexScratch);
    for (std::size_t s = 0; s < count; ++s)
      if (s == 0 || keys[s] != keys[s - 1]) {
        out.ownGroupStart.push_back(static_cast<std::uint32_t>(s));
        out.ownGroupKey.push_back(keys[s]);
      }
    out.ownGroupStart.push_back(static_cast<std::uint32_t>(count));
    out.queryOrder = out.ownOrder.data();
    out.groupStart = out.ownGroupStart.data();
    out.groupKey = out.ownGroupKey.data();
    out.groups = out.ownGroupKey.size();
  }
  const std::size_t target = std::max<std::size_t>(512, count / 256);
  out.chunkGroup.assign(1, 0);
  out.chunkStart.assign(1, 0);
  for (std::size_t g = 0; g < out.groups; ++g)
    if (out.groupStart[g + 1] - out.groupStart[out.chunkGroup.back()] >= target || g + 1 == out.groups) {
      out.chunkGroup.push_back(g + 1);
      out.chunkStart.push_back(out.groupStart[g + 1]);
    }
}

void UniformGridSearch::query(const Vec3r* queries, std::size_t count, const Real* supportRadii,
                              bool excludeSelf, NeighborLists& out) const {
  if (count == 0 || mCount == 0) {
    out.setEmpty(count);
    return;
  }
  std::unique_lock<std::mutex> lock(mScratchMutex, std::try_to_lock);
  ListScratch localScratch;
  ListScratch& scratch = lock.owns_lock() ? mScratch : localScratch;

  QueryGroups groups;
  groupQueries(queries, count, groups);
  const GridQuery job{*this,        queries,           supportRadii,      excludeSelf,
                      groups.self, groups.queryOrder, groups.groupStart, groups.groupKey};
  const bool avx2 = searchUsesAvx2(), avx512 = searchUsesAvx512();
  assembleLists(count, groups.queryOrder, groups.chunkStart, scratch, out,
                [&](std::size_t chunk, std::uint32_t, std::uint32_t, ChunkWriter& writer) {
                  if (avx512)
                    runGridChunkAvx512(job, groups.chunkGroup[chunk], groups.chunkGroup[chunk + 1], writer);
                  else if (avx2)
                    runGridChunkAvx2(job, groups.chunkGroup[chunk], groups.chunkGroup[chunk + 1], writer);
                  else
                    job.runChunk<ScanBaseline>(groups.chunkGroup[chunk], groups.chunkGroup[chunk + 1], writer);
                });
}

void UniformGridSearch::visitQueryGroups(const Vec3r* queries, std::size_t count, GroupVisit visit,
                                         void* context) const {
  if (count == 0) return;
  if (mCount == 0) {
    for (std::uint32_t q = 0; q < count; ++q) visit(context, &q, 1, nullptr, 0);
    return;
  }
  QueryGroups groups;
  groupQueries(queries, count, groups);
  // A group's queries in ascending index (the sort keeps index order within a
  // cell; a self query's cell lists its points in index order too).
  const GridQuery job{*this, queries, nullptr, false, groups.self, groups.queryOrder, groups.groupStart,
                      groups.groupKey};
  const std::size_t chunks = groups.chunkStart.size() - 1;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks, 1), [&](const auto& range) {
    GridQuery::Stencil stencil;
    std::vector<PlaceRange> boxRanges;
    for (std::size_t c = range.begin(); c != range.end(); ++c)
      for (std::size_t g = groups.chunkGroup[c]; g < groups.chunkGroup[c + 1]; ++g) {
        const std::uint32_t* members = groups.queryOrder + groups.groupStart[g];
        const std::uint32_t size = groups.groupStart[g + 1] - groups.groupStart[g];
        if (mSelfStencilOk) {
          // The build radius reaches one cell: the 27 cells around the group's
          // (clamped) cell hold every neighbour of its queries, also of those
          // outside the occupied box that were clamped onto its border.
          job.makeStencil(groups.groupKey[g], stencil);
          visit(context, members, size, stencil.merged.data(), std::uint32_t(stencil.mergedCount));
          continue;
        }
        // Cells clamped at the lattice's edge: each query its own box of cells.
        for (std::uint32_t k = 0; k < size; ++k) {
          boxRanges.clear();
          job.forEachCellAround(queries[members[k]], mRadius, [&](std::uint32_t begin, std::uint32_t end) {
            boxRanges.push_back({begin, end});
          });
          std::sort(boxRanges.begin(), boxRanges.end(),
                    [](const PlaceRange& a, const PlaceRange& b) { return a.begin < b.begin; });
          visit(context, members + k, 1, boxRanges.data(), std::uint32_t(boxRanges.size()));
        }
      }
  });
}

} // namespace cascade::search
