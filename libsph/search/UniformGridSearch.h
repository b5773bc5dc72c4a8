/// @file UniformGridSearch.h
/// @brief Fixed-radius neighbour search on a uniform grid of cells of edge the
///        support radius, the cells ordered along a Z-order (Morton) curve:
///        the CompactNSearch approach (Band, Gissler & Teschner 2017; cell
///        lists of Hockney & Eastwood / Monaghan 1985, the "linked list" of
///        SEED section 2.1).
///
/// build() keys every point by the Morton code of its cell, sorts the points
/// by key (parallel radix sort) and keeps a copy of their positions in that
/// order, so that the points of a cell and of its neighbour cells sit together
/// in memory. A hash table maps occupied cells to their range of points.
/// When the points moved little since the last build, only the points whose
/// cell changed are sorted again and merged into the kept order (incremental
/// rebuild). Either way the order is canonical (by cell along the curve, then
/// by point index), so the neighbour lists, their order included, depend only
/// on the current points: an incremental rebuild gives bit for bit the lists
/// of a full one (a resumed simulation stays bit-identical).
///
/// query() walks the queries cell by cell: the 27 cells around a query's cell
/// are looked up once per cell, then every point of them is tested with
/// squaredDistance() (the exact relation of NeighborSearch.h, so the sets equal
/// brute force). A self query with the build radius first packs the 27 cells'
/// points within the radius of the box around the cell's queries into one run
/// (in place order: the same lists) and scans that. Queries may be another point set (fluid against boundary
/// particles) and may have their own radius (gather form); a radius larger
/// than the build radius is allowed (slower: more cells are visited).
///
/// The cell edge is the build radius enlarged by 2^-10 so that rounding can
/// never put a neighbour outside the 27 cells; each query also bounds its
/// cell range conservatively, so no neighbour is ever missed.
#pragma once

#include "libsph/NeighborSearch.h"
#include "libsph/search/ListAssembly.h"

#include <cstdint>
#include <mutex>
#include <type_traits>
#include <vector>

namespace cascade::search {

class UniformGridSearch final : public NeighborSearch {
public:
  std::string name() const override { return "grid"; }
  void build(const Vec3r* points, std::size_t count, Real maxSupportRadius) override;
  /// Not reentrant for concurrent calls on the same object (it reuses scratch memory).
  void query(const Vec3r* queries, std::size_t count, const Real* supportRadii, bool excludeSelf,
             NeighborLists& out) const override;

  /// Place ranges [begin, end) of the last build (see placeOrder()).
  struct PlaceRange {
    std::uint32_t begin, end;
  };

  /// Candidate form of a query with the build radius, for a pass that tests
  /// the distances itself (and so keeps no lists): calls
  /// visit(queryIndices, queryCount, ranges, rangeCount) for groups of queries,
  /// each query in exactly one group. Every point within the build radius of a
  /// group's query (squaredDistance() <= radius^2) sits at a place in one of the
  /// group's ranges, which hold other points too; ranges do not overlap and
  /// ascend. A group is the queries of one grid cell (the 27 cells around it),
  /// in ascending index, so the groups and their ranges depend only on the
  /// points and the queries. Groups are visited from several threads at once.
  template <typename Visit>
  void forEachQueryGroup(const Vec3r* queries, std::size_t count, Visit&& visit) const {
    using V = std::remove_reference_t<Visit>;
    visitQueryGroups(
        queries, count,
        [](void* context, const std::uint32_t* group, std::uint32_t size, const PlaceRange* ranges,
           std::uint32_t rangeCount) { (*static_cast<V*>(context))(group, size, ranges, rangeCount); },
        const_cast<void*>(static_cast<const void*>(&visit)));
  }

  /// The last build's points by place (curve order): placeOrder()[k] is the
  /// index of the point at place k, at (placeX()[k], placeY()[k], placeZ()[k]).
  const std::uint32_t* placeOrder() const { return mOrder.data(); }
  const Real* placeX() const { return mX.data(); }
  const Real* placeY() const { return mY.data(); }
  const Real* placeZ() const { return mZ.data(); }
  std::size_t pointCount() const { return mCount; }

  /// The Z-order of the last build: order[k] is the index of the point at
  /// place k along the curve. Particles::permute(zOrder()) sorts particles so
  /// that later searches (and every solver pass) touch memory in order.
  std::vector<std::size_t> zOrder() const;

  /// Canonical order (NeighborSearch::setCanonicalOrder): the lattice's origin at
  /// `anchor` instead of snapped to the points' bounds, and the points of a cell by
  /// id instead of by index (full builds only). The stencil scan emits the places of
  /// the 27 cells in ascending order, so a list ascends by (cell key, id).
  bool setCanonicalOrder(const ParticleId* ids, const Vec3r& anchor) override;

  /// Allows (default) or forbids the incremental rebuild (for benchmarks).
  void setIncrementalBuild(bool enabled) { mIncremental = enabled; }
  /// Whether the last build() reused the previous order (incremental rebuild).
  bool lastBuildWasIncremental() const { return mLastIncremental; }
  /// Points whose cell changed in the last incremental build.
  std::size_t lastBuildMovedCount() const { return mLastMoved; }

  /// Number of occupied cells of the last build.
  std::size_t cellCount() const { return mCellStart.empty() ? 0 : mCellStart.size() - 1; }
  Real cellSize() const { return static_cast<Real>(mCellSize); }

private:
  struct Frame;
  struct QueryGroups;
  void groupQueries(const Vec3r* queries, std::size_t count, QueryGroups& out) const;
  using GroupVisit = void (*)(void* context, const std::uint32_t* group, std::uint32_t size,
                              const PlaceRange* ranges, std::uint32_t rangeCount);
  void visitQueryGroups(const Vec3r* queries, std::size_t count, GroupVisit visit, void* context) const;
  void computeFrame(const Vec3r* points, std::size_t count, Real maxSupportRadius);
  void sortPoints(const Vec3r* points, std::size_t count, bool sameFrame);
  void buildCells();
  /// Index of the occupied cell at (x, y, z), or -1.
  std::int64_t findCell(std::uint32_t x, std::uint32_t y, std::uint32_t z) const;

  friend struct GridQuery;

  const Vec3r* mPoints = nullptr;
  std::size_t mCount = 0;
  Real mRadius = 0;

  // Frame: cell (i, j, k) of point p is floor((p - origin) / cellSize), clamped to [0, 2^21).
  double mOrigin[3] = {0, 0, 0};
  double mCellSize = 1, mInvCellSize = 1;
  std::uint32_t mMaxCell[3] = {0, 0, 0};  ///< largest occupied cell coordinate per axis

  std::vector<std::uint64_t> mKeys;    ///< Morton key per place, ascending
  std::vector<std::uint32_t> mOrder;   ///< point index per place
  std::vector<Real> mX, mY, mZ;        ///< positions per place (padded)
  std::vector<std::uint32_t> mCellStart;  ///< first place of each occupied cell, plus the end
  std::vector<std::uint64_t> mCellKey;    ///< Morton key of each occupied cell
  // Cell lookup: a dense table over the occupied box when it is small enough
  // (compact fluid), else a hash table (open addressing) on the Morton key.
  struct HashEntry {
    std::uint64_t key;
    std::uint32_t cell;  ///< cell index + 1, 0 empty
  };
  std::vector<std::uint32_t> mDense;  ///< cell index + 1 per (x, y, z), 0 empty
  bool mUseDense = false;
  std::vector<HashEntry> mHash;
  std::uint64_t mHashMask = 0;

  const ParticleId* mIds = nullptr;     ///< canonical order: tie-break within a cell
  double mAnchor[3] = {0, 0, 0};        ///< canonical order: the fixed origin
  bool mIncremental = true;
  bool mLastIncremental = false;
  std::size_t mLastMoved = 0;
  bool mHaveFrame = false;
  /// Every point's cell is unclamped and the build radius reaches at most one
  /// cell: a self query with the build radius needs only the 27 cells.
  bool mSelfStencilOk = false;

  // Scratch reused between builds and queries.
  std::vector<std::uint64_t> mKeyScratch, mKeyScratch2;
  std::vector<std::uint32_t> mIndexScratch, mIndexScratch2;
  mutable std::mutex mScratchMutex;
  mutable ListScratch mScratch;
};

} // namespace cascade::search
