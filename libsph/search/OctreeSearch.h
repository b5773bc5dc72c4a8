/// @file OctreeSearch.h
/// @brief The SEED's neighbour search (section 2.1): an octree over the points,
///        space split recursively until each leaf holds at most one particle;
///        the query of particle i walks the tree with the cube of edge
///        2 kappa h_i around it (here: edge 2 x its support radius) and keeps
///        the particles of the leaves it meets that lie within the support
///        (squaredDistance(), so the sets equal brute force).
///
/// Construction: points are quantised to a 2^21 lattice over their bounding
/// cube and sorted by the Morton code of their lattice cell (parallel radix
/// sort); every octree node is then a contiguous run of the sorted points
/// whose codes share a prefix, and its children split the run by the next
/// three bits. A node whose points all fall into one child is not stored
/// (its only child takes its place: the cubes are the same octree cubes, the
/// chain of one-child nodes is just skipped). Points that share a lattice cell
/// (duplicates) cannot be split and share one leaf. The tree is stored as
/// one record per inner node holding its children (ChildBlock below: the
/// children's cubes, point runs and records side by side, so a walk step tests
/// all children of a node at once and touches three cache lines); the top of
/// the tree is split breadth first, the subtrees below in parallel, each into
/// its own region of a buffer kept between builds, depth first along the curve.
///
/// Query: the cube is mapped to the same lattice (conservatively, so that no
/// point within the radius is missed), the walk descends into every node whose
/// cube overlaps the query cube; a node whose cube lies inside the query cube
/// contributes all its points without further descent (they all pass the cube
/// test), each then tested exactly. Each query has its own radius (variable
/// smoothing length), of any size.
///
/// leafSize > 1 gives a bucket octree (leaves of up to leafSize particles), a
/// faster variant; leafSize = 1 (the default, "octree") is the SEED's tree.
#pragma once

#include "libsph/NeighborSearch.h"
#include "libsph/search/ListAssembly.h"

#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

namespace cascade::search {

class OctreeSearch final : public NeighborSearch {
public:
  explicit OctreeSearch(std::size_t leafSize = 1) : mLeafSize(leafSize < 1 ? 1 : leafSize) {}

  std::string name() const override { return mLeafSize == 1 ? "octree" : "octree-bucket"; }
  void build(const Vec3r* points, std::size_t count, Real maxSupportRadius) override;
  /// Not reentrant for concurrent calls on the same object (it reuses scratch memory).
  void query(const Vec3r* queries, std::size_t count, const Real* supportRadii, bool excludeSelf,
             NeighborLists& out) const override;

  std::size_t leafSize() const { return mLeafSize; }
  /// Number of nodes (leaves included; counted by a walk, for tests).
  std::size_t nodeCount() const;
  /// Largest number of points in one leaf (1 unless points coincide, or leafSize > 1).
  std::size_t largestLeaf() const;
  /// Depth of the finest leaf (root = 0; one level per halving of the cube edge).
  int depth() const;

  /// A node: the points at places [begin, end), the cube of lattice cells
  /// [corner, corner + 2^(21 - level)) per axis, children at
  /// [firstChild, firstChild + childCount) (none for a leaf).
  struct Node {
    std::uint32_t corner[3];
    std::uint32_t begin, end;
    std::uint32_t firstChild;
    std::uint8_t level, childCount;
  };
  /// The tree as a node list, breadth first from the root (made on demand, for tests).
  std::vector<Node> nodes() const;

  /// The layout the tree is stored and walked in: the children of each inner
  /// node in one cache-line aligned record, each field an array over the (up
  /// to eight) children, so one walk step tests all children's cubes at once
  /// (SIMD) and reads one record instead of one node per child. Child k holds
  /// the places [begin[k], begin[k + 1]), its cube is [lo, lo + 2^(21 - level[k]))
  /// per axis, and its own children are record block[k] (kLeaf for a leaf).
  /// Unused lanes have a cube outside the lattice (lo = 2^30) and meet nothing.
  /// Record 0 holds the root alone.
  struct alignas(64) ChildBlock {
    std::uint32_t lo[3][8];
    std::uint32_t begin[9];
    std::uint32_t block[8];
    std::uint8_t level[8];
  };
  static constexpr std::uint32_t kLeaf = 0xffffffffu;

private:
  friend struct OctreeQuery;
  void buildTree();
  template <typename InnerChild>
  void splitNode(ChildBlock& block, std::uint32_t begin, std::uint32_t end, int level,
                 InnerChild&& innerChild) const;
  static void setLane(ChildBlock& block, unsigned lane, std::uint32_t begin, int level, std::uint64_t key);
  static void closeBlock(ChildBlock& block, unsigned used, std::uint32_t end);

  std::size_t mLeafSize;
  const Vec3r* mPoints = nullptr;
  std::size_t mCount = 0;
  Real mRadius = 0;
  double mOrigin[3] = {0, 0, 0};
  double mScale = 1;  ///< lattice cells per metre

  std::vector<std::uint64_t> mKeys;   ///< Morton code per place, ascending
  std::vector<std::uint32_t> mOrder;  ///< point index per place
  std::vector<Real> mX, mY, mZ;       ///< positions per place (padded)
  /// The tree's records (see ChildBlock), mBlockCount of them in use; kept
  /// between builds.
  std::unique_ptr<ChildBlock[]> mBlocks;
  std::size_t mBlockCount = 0, mBlockCapacity = 0;

  std::vector<std::uint64_t> mKeyScratch;
  std::vector<std::uint32_t> mIndexScratch;
  mutable std::mutex mScratchMutex;
  mutable ListScratch mScratch;
};

} // namespace cascade::search
