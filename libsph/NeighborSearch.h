/// @file NeighborSearch.h
/// @brief Fixed-radius neighbour search: the interface the solver, the
///        surfacing stage and the benchmarks share, and its implementations.
///
/// A query point q has as neighbours every indexed point p with
/// |q - p|^2 <= r^2 (inclusive: a point exactly on the support radius counts),
/// the squared distance computed by squaredDistance() below in every
/// implementation, so that all implementations return bit-identical sets.
/// With a per-query radius (variable smoothing length, SEED section 2.1) the
/// relation is the gather form: r = supportRadii[q].
///
/// Lists are compressed rows (CSR) and are built once per time step; every
/// later pass of that step reads them.
#pragma once

#include "libsph/Types.h"

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace cascade {

/// The one place the neighbour relation's distance is computed.
inline Real squaredDistance(const Vec3r& a, const Vec3r& b) {
  const Real dx = a.x() - b.x(), dy = a.y() - b.y(), dz = a.z() - b.z();
  return dx * dx + dy * dy + dz * dz;
}

/// Neighbour lists in compressed-row form: the neighbours of query i are
/// indices[offsets[i] .. endOffset(i)). Order within a list is unspecified.
/// Packed (ends empty), list i ends where list i + 1 begins, at offsets[i + 1].
/// With room between lists (ends holds each list's end), a search writes every
/// list straight into place, with no copy (search/ListAssembly.h); indices then
/// also holds unused entries, and offsets[size()] is indices.size(). `order`
/// then says in which order the lists lie in memory (the search's own order,
/// which drifts from the particles' as they move between reorders), so that a
/// pass over every list can read them front to back (solver/ListOrder.h).
struct NeighborLists {
  std::vector<std::uint32_t> offsets{0};
  std::vector<std::uint32_t> ends;   ///< empty: packed; else list i ends at indices[ends[i]]
  std::vector<std::uint32_t> order;  ///< empty: lists in query order; else the k-th list in memory is order[k]'s
  std::vector<std::uint32_t> indices;
  std::size_t pairs = 0;  ///< the lists' total length when not packed

  std::size_t size() const { return offsets.size() - 1; }
  std::uint32_t endOffset(std::size_t i) const { return ends.empty() ? offsets[i + 1] : ends[i]; }
  std::uint32_t count(std::size_t i) const { return endOffset(i) - offsets[i]; }
  const std::uint32_t* begin(std::size_t i) const { return indices.data() + offsets[i]; }
  const std::uint32_t* end(std::size_t i) const { return indices.data() + endOffset(i); }
  /// The number of neighbour entries (pairs) in all lists.
  std::size_t totalCount() const { return ends.empty() ? indices.size() : pairs; }
  void clear() { setEmpty(0); }
  /// `count` empty lists.
  void setEmpty(std::size_t count) {
    offsets.assign(count + 1, 0);
    ends.clear();
    order.clear();
    indices.clear();
    pairs = 0;
  }
};

/// A neighbour search method. build() indexes a point set; query() finds, for
/// each query point, the indexed points within its support radius.
class NeighborSearch {
public:
  virtual ~NeighborSearch() = default;

  /// Short method name as used in scenes and benchmarks ("brute", "grid", "octree").
  virtual std::string name() const = 0;

  /// Indexes `count` points for later queries of radius at most maxSupportRadius.
  /// The points must stay alive and unchanged until the next build().
  virtual void build(const Vec3r* points, std::size_t count, Real maxSupportRadius) = 0;

  /// For each of `count` queries, the indexed points within its radius:
  /// supportRadii[q] if supportRadii is not null, else the build radius.
  /// With excludeSelf, the queries are the indexed points themselves and
  /// query i does not list point i.
  virtual void query(const Vec3r* queries, std::size_t count, const Real* supportRadii,
                     bool excludeSelf, NeighborLists& out) const = 0;

  /// Asks the next builds to list neighbours in a canonical order: ascending by the
  /// cell of a fixed lattice anchored at `anchor` (the same on every call), then by
  /// `ids` (one per point, valid for the next build), so that a query's list depends
  /// only on the points within its radius, not on which other points are indexed or
  /// where they are stored (MPI ranks, DomainPartition.h). ids null: back to the
  /// method's own order. Returns false if the method cannot (the caller then sorts).
  virtual bool setCanonicalOrder(const ParticleId* ids, const Vec3r& anchor) {
    (void)ids;
    (void)anchor;
    return false;
  }

  /// Convenience: all pairs within one point set (build + self query).
  void findNeighbors(const Vec3r* points, std::size_t count, Real supportRadius,
                     NeighborLists& out) {
    build(points, count, supportRadius);
    query(points, count, nullptr, true, out);
  }
};

/// The reference: tests every pair. O(N^2); for tests and small sets only.
class BruteForceSearch final : public NeighborSearch {
public:
  std::string name() const override { return "brute"; }
  void build(const Vec3r* points, std::size_t count, Real maxSupportRadius) override;
  void query(const Vec3r* queries, std::size_t count, const Real* supportRadii,
             bool excludeSelf, NeighborLists& out) const override;

private:
  const Vec3r* mPoints = nullptr;
  std::size_t mCount = 0;
  Real mRadius = 0;
};

/// Creates a search by method name; throws std::invalid_argument for an unknown one.
std::unique_ptr<NeighborSearch> makeNeighborSearch(const std::string& method);

/// The method names makeNeighborSearch() accepts.
std::vector<std::string> neighborSearchMethods();

/// The Z-order (Morton curve over cells of edge cellSize, e.g. the support
/// radius) of a point set: order[k] is the index of the point that goes to
/// place k. Particles::permute(order) puts particles that are close in space
/// close in memory (CompactNSearch's reordering), which speeds up the searches
/// and every solver pass over neighbour lists; redo it every few steps.
std::vector<std::size_t> zOrderPermutation(const Vec3r* points, std::size_t count, Real cellSize);

/// Concatenates per-query lists (built in parallel) into compressed rows.
void assembleNeighborLists(const std::vector<std::vector<std::uint32_t>>& perQuery,
                           NeighborLists& out);

} // namespace cascade
