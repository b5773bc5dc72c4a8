// Every search method returns exactly the neighbour sets of brute force
// (NeighborSearch.h: |q - p|^2 <= r^2 by squaredDistance(), inclusive).
#include "libsph/NeighborSearch.h"
#include "libsph/Particles.h"
#include "libsph/search/CellKeys.h"
#include "libsph/search/ListAssembly.h"
#include "libsph/search/MortonCode.h"
#include "libsph/search/OctreeSearch.h"
#include "libsph/search/ScanRange.h"
#include "libsph/search/UniformGridSearch.h"
#include "libsph/solver/ListOrder.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>
#include <numeric>
#include <random>
#include <set>

using namespace cascade;

namespace {

using Sets = std::vector<std::vector<std::uint32_t>>;

Sets toSets(const NeighborLists& lists) {
  Sets sets(lists.size());
  for (std::size_t q = 0; q < lists.size(); ++q) {
    sets[q].assign(lists.begin(q), lists.end(q));
    std::sort(sets[q].begin(), sets[q].end());
  }
  return sets;
}

/// The lists in order, each as the search wrote it (whatever room lies between them).
Sets inOrder(const NeighborLists& lists) {
  Sets sets(lists.size());
  for (std::size_t q = 0; q < lists.size(); ++q) sets[q].assign(lists.begin(q), lists.end(q));
  return sets;
}

Sets bruteSets(const std::vector<Vec3r>& points, const std::vector<Vec3r>& queries, Real radius,
               const std::vector<Real>* radii, bool excludeSelf) {
  BruteForceSearch brute;
  NeighborLists lists;
  brute.build(points.data(), points.size(), radius);
  brute.query(queries.data(), queries.size(), radii ? radii->data() : nullptr, excludeSelf, lists);
  return toSets(lists);
}

/// The registered methods, plus the bucket octree variant.
std::unique_ptr<NeighborSearch> makeSearch(const std::string& method) {
  if (method == "octree_bucket8") return std::make_unique<search::OctreeSearch>(8);
  return makeNeighborSearch(method);
}

/// Every list lies inside `indices`, no two share an entry, and totalCount() is their
/// total length (packed or with room between them).
void expectDisjointRows(const NeighborLists& lists) {
  ASSERT_TRUE(lists.ends.empty() || lists.ends.size() == lists.size());
  std::vector<std::pair<std::uint32_t, std::uint32_t>> rows;
  std::size_t total = 0;
  for (std::size_t q = 0; q < lists.size(); ++q) {
    ASSERT_LE(lists.offsets[q], lists.endOffset(q)) << q;
    ASSERT_LE(lists.endOffset(q), lists.indices.size()) << q;
    if (lists.count(q)) rows.emplace_back(lists.offsets[q], lists.endOffset(q));
    total += lists.count(q);
  }
  std::sort(rows.begin(), rows.end());
  for (std::size_t r = 1; r < rows.size(); ++r) ASSERT_LE(rows[r - 1].second, rows[r].first) << r;
  EXPECT_EQ(lists.totalCount(), total);
}

/// Compares a method against brute force, list by list, and checks the CSR shape.
void expectSameAsBrute(const std::string& method, const std::vector<Vec3r>& points,
                       const std::vector<Vec3r>* otherQueries, Real radius,
                       const std::vector<Real>* radii = nullptr, bool excludeSelf = true) {
  const std::vector<Vec3r>& queries = otherQueries ? *otherQueries : points;
  const Sets expected = bruteSets(points, queries, radius, radii, otherQueries ? false : excludeSelf);
  auto search = makeSearch(method);
  NeighborLists lists;
  search->build(points.data(), points.size(), radius);
  search->query(queries.data(), queries.size(), radii ? radii->data() : nullptr,
                otherQueries ? false : excludeSelf, lists);
  ASSERT_EQ(lists.offsets.size(), queries.size() + 1);
  ASSERT_EQ(lists.offsets.back(), lists.indices.size());
  expectDisjointRows(lists);
  const Sets got = toSets(lists);
  std::size_t total = 0;
  for (std::size_t q = 0; q < queries.size(); ++q) {
    total += expected[q].size();
    ASSERT_EQ(got[q], expected[q]) << method << ": query " << q << " at (" << queries[q].transpose()
                                   << ")";
    // No duplicates within a list.
    ASSERT_TRUE(std::adjacent_find(got[q].begin(), got[q].end()) == got[q].end());
  }
  EXPECT_EQ(lists.totalCount(), total);
}

std::vector<Vec3r> uniformPoints(std::size_t n, Real extent, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<Real> u(0, extent);
  std::vector<Vec3r> points(n);
  for (auto& p : points) p = Vec3r(u(rng), u(rng), u(rng));
  return points;
}

/// A dam-break block (jittered lattice) plus scattered droplets far and near.
std::vector<Vec3r> damBreakWithDroplets(Real spacing, int nx, int ny, int nz, std::size_t droplets,
                                        unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<Real> jitter(-0.05f * spacing, 0.05f * spacing);
  std::vector<Vec3r> points;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        points.emplace_back(i * spacing + jitter(rng), j * spacing + jitter(rng),
                            k * spacing + jitter(rng));
  std::uniform_real_distribution<Real> spread(-2 * nx * spacing, 4 * nx * spacing);
  for (std::size_t d = 0; d < droplets; ++d) {
    Vec3r center(spread(rng), spread(rng), std::abs(spread(rng)));
    const int blob = 1 + int(d % 5);
    for (int b = 0; b < blob; ++b)
      points.push_back(center + Vec3r(jitter(rng), jitter(rng), jitter(rng)) * 10);
  }
  return points;
}

class SearchMethod : public ::testing::TestWithParam<std::string> {};

} // namespace

TEST(NeighborSearchRegistry, KnowsEveryMethod) {
  const auto methods = neighborSearchMethods();
  for (const char* name : {"brute", "grid", "octree"}) {
    ASSERT_NE(std::find(methods.begin(), methods.end(), name), methods.end()) << name;
    EXPECT_EQ(makeNeighborSearch(name)->name(), name);
  }
  EXPECT_THROW(makeNeighborSearch("kd-tree"), std::invalid_argument);
}

TEST_P(SearchMethod, UniformRandomPoints) {
  const auto points = uniformPoints(4000, 1.0f, 1);
  expectSameAsBrute(GetParam(), points, nullptr, 0.12f);  // ~29 neighbours
  expectSameAsBrute(GetParam(), points, nullptr, 0.12f, nullptr, false);
}

TEST_P(SearchMethod, ClusteredDamBreakAndDroplets) {
  const auto points = damBreakWithDroplets(0.01f, 16, 12, 14, 300, 2);
  expectSameAsBrute(GetParam(), points, nullptr, 0.0203f);
}

TEST_P(SearchMethod, VariableSmoothingLengths) {
  const auto points = damBreakWithDroplets(0.01f, 12, 12, 12, 100, 3);
  std::mt19937 rng(4);
  std::uniform_real_distribution<Real> u(0.002f, 0.03f);
  std::vector<Real> radii(points.size());
  for (auto& r : radii) r = u(rng);
  // Build radius is the largest query radius (the grid's contract) ...
  expectSameAsBrute(GetParam(), points, nullptr, 0.03f, &radii);
  // ... but a smaller build radius is also answered exactly.
  expectSameAsBrute(GetParam(), points, nullptr, 0.01f, &radii);
}

TEST_P(SearchMethod, EmptyAndOneParticle) {
  const std::vector<Vec3r> none;
  const std::vector<Vec3r> one{Vec3r(0.5f, -2, 3)};
  expectSameAsBrute(GetParam(), none, nullptr, 0.1f);
  expectSameAsBrute(GetParam(), one, nullptr, 0.1f);
  expectSameAsBrute(GetParam(), one, nullptr, 0.1f, nullptr, false);
  expectSameAsBrute(GetParam(), none, &one, 0.1f);  // query against nothing
  expectSameAsBrute(GetParam(), one, &none, 0.1f);  // no queries
  const std::vector<Vec3r> twins{Vec3r(1, 1, 1), Vec3r(1, 1, 1)};
  expectSameAsBrute(GetParam(), twins, nullptr, 0.0f);  // radius 0: coincident points only
  expectSameAsBrute(GetParam(), twins, nullptr, 0.5f);
}

TEST_P(SearchMethod, ExactlyOnTheSupportRadiusAndOnCellBorders) {
  // Lattice of spacing 1/4 with radius 1/2: many pairs at exactly 1/2 (axis
  // neighbours two apart), all coordinates and squared distances exact in float.
  std::vector<Vec3r> lattice;
  for (int k = -4; k <= 4; ++k)
    for (int j = -4; j <= 4; ++j)
      for (int i = -4; i <= 4; ++i) lattice.emplace_back(0.25f * i, 0.25f * j, 0.25f * k);
  // 3-4-5 triangles scaled by 1/8: distance exactly 0.625 from the centre.
  lattice.emplace_back(0.375f, 0.5f, 0.0f);
  lattice.emplace_back(0.0f, -0.375f, 0.5f);
  expectSameAsBrute(GetParam(), lattice, nullptr, 0.5f);
  expectSameAsBrute(GetParam(), lattice, nullptr, 0.625f);
  expectSameAsBrute(GetParam(), lattice, nullptr, 0.25f);

  // Points exactly on the grid's cell borders (multiples of its cell edge,
  // exact in float) and on the far side of the support radius from them.
  search::UniformGridSearch probe;
  probe.build(lattice.data(), lattice.size(), 0.5f);
  const Real cell = probe.cellSize();
  std::vector<Vec3r> borders;
  for (int k = -3; k <= 3; ++k)
    for (int j = -3; j <= 3; ++j)
      for (int i = -3; i <= 3; ++i) {
        const Vec3r p(cell * i, cell * j, cell * k);
        borders.push_back(p);
        borders.push_back(p + Vec3r(0.5f, 0, 0));
        borders.push_back(p + Vec3r(0, 0, -0.5f));
      }
  for (const Real radius : {0.5f, cell}) expectSameAsBrute(GetParam(), borders, nullptr, radius);
}

TEST_P(SearchMethod, QueriesAgainstAnotherPointSet) {
  // Fluid particles (queries) against boundary particles on a floor and a wall,
  // with queries also far outside the boundary's bounding box.
  std::vector<Vec3r> boundary;
  for (int j = 0; j < 40; ++j)
    for (int i = 0; i < 40; ++i) {
      boundary.emplace_back(i * 0.025f, j * 0.025f, 0.0f);
      boundary.emplace_back(0.0f, i * 0.025f, j * 0.025f);
    }
  auto fluid = uniformPoints(3000, 1.0f, 5);
  fluid.emplace_back(-5, -5, -5);
  fluid.emplace_back(100, 0.5f, 0.5f);
  fluid.emplace_back(0.5f, 0.5f, -0.04f);
  expectSameAsBrute(GetParam(), boundary, &fluid, 0.05f);
  std::vector<Real> radii(fluid.size());
  for (std::size_t q = 0; q < fluid.size(); ++q) radii[q] = 0.01f + 0.04f * Real(q % 7) / 6;
  expectSameAsBrute(GetParam(), boundary, &fluid, 0.05f, &radii);
}

TEST_P(SearchMethod, RadiusLargerThanBuildRadius) {
  const auto points = uniformPoints(1500, 1.0f, 6);
  std::vector<Real> radii(points.size(), 0.2f);
  radii[0] = 3.0f;  // everything
  expectSameAsBrute(GetParam(), points, nullptr, 0.05f, &radii);
}

TEST_P(SearchMethod, RepeatedBuildsAfterSmallMovesAndReordering) {
  auto points = damBreakWithDroplets(0.01f, 14, 10, 10, 50, 7);
  std::mt19937 rng(8);
  std::uniform_real_distribution<Real> step(-0.002f, 0.002f);
  auto search = makeSearch(GetParam());
  for (int frame = 0; frame < 4; ++frame) {
    NeighborLists lists;
    search->findNeighbors(points.data(), points.size(), 0.0203f, lists);
    ASSERT_EQ(toSets(lists), bruteSets(points, points, 0.0203f, nullptr, true)) << "frame " << frame;
    for (auto& p : points) p += Vec3r(step(rng), step(rng), step(rng));
    if (frame == 1) std::reverse(points.begin(), points.end());
  }
}

INSTANTIATE_TEST_SUITE_P(Methods, SearchMethod, ::testing::Values("grid", "octree", "octree_bucket8"),
                         [](const auto& info) { return info.param; });

TEST(UniformGridSearch, IncrementalRebuildMatchesFullRebuild) {
  auto points = damBreakWithDroplets(0.01f, 20, 20, 20, 0, 9);
  search::UniformGridSearch incremental, full;
  full.setIncrementalBuild(false);
  incremental.build(points.data(), points.size(), 0.0203f);
  // The solver's usage: reorder the particles along the curve, then step.
  Particles particles;
  for (std::size_t i = 0; i < points.size(); ++i) particles.add(points[i], Vec3r::Zero(), ParticleId(i));
  particles.permute(incremental.zOrder());
  std::mt19937 rng(10);
  std::uniform_real_distribution<Real> step(-0.0002f, 0.0002f);
  for (auto& p : particles.position) p += Vec3r(step(rng), step(rng), step(rng));
  incremental.build(particles.position.data(), particles.size(), 0.0203f);
  full.build(particles.position.data(), particles.size(), 0.0203f);
  EXPECT_TRUE(incremental.lastBuildWasIncremental());
  EXPECT_GT(incremental.lastBuildMovedCount(), 0u);
  EXPECT_LT(incremental.lastBuildMovedCount(), particles.size() / 4);
  // The same canonical order (cell, then point index), whatever the history.
  EXPECT_EQ(incremental.zOrder(), full.zOrder());
  NeighborLists a, b;
  incremental.query(particles.position.data(), particles.size(), nullptr, true, a);
  full.query(particles.position.data(), particles.size(), nullptr, true, b);
  // Bit for bit the same lists, order within each list included.
  EXPECT_EQ(inOrder(a), inOrder(b));
  // And after a second step that moves particles between cells the other way.
  for (auto& p : particles.position) p -= Vec3r(step(rng), step(rng), step(rng));
  incremental.build(particles.position.data(), particles.size(), 0.0203f);
  full.build(particles.position.data(), particles.size(), 0.0203f);
  EXPECT_TRUE(incremental.lastBuildWasIncremental());
  EXPECT_EQ(incremental.zOrder(), full.zOrder());
  incremental.query(particles.position.data(), particles.size(), nullptr, true, a);
  full.query(particles.position.data(), particles.size(), nullptr, true, b);
  EXPECT_EQ(inOrder(a), inOrder(b));
}

TEST(UniformGridSearch, IncrementalRebuildFromThePreviousOrderIsCanonical) {
  // Points not reordered by the caller: the previous curve order is the base.
  auto points = damBreakWithDroplets(0.01f, 16, 16, 16, 20, 15);
  std::shuffle(points.begin(), points.end(), std::mt19937(16));
  search::UniformGridSearch incremental, full;
  full.setIncrementalBuild(false);
  incremental.build(points.data(), points.size(), 0.0203f);
  std::mt19937 rng(17);
  std::uniform_real_distribution<Real> step(-0.0003f, 0.0003f);
  for (int frame = 0; frame < 3; ++frame) {
    for (auto& p : points) p += Vec3r(step(rng), step(rng), step(rng));
    incremental.build(points.data(), points.size(), 0.0203f);
    full.build(points.data(), points.size(), 0.0203f);
    EXPECT_TRUE(incremental.lastBuildWasIncremental());
    EXPECT_GT(incremental.lastBuildMovedCount(), 0u);
    ASSERT_EQ(incremental.zOrder(), full.zOrder()) << frame;
    NeighborLists a, b;
    incremental.query(points.data(), points.size(), nullptr, true, a);
    full.query(points.data(), points.size(), nullptr, true, b);
    ASSERT_EQ(inOrder(a), inOrder(b)) << frame;
    ASSERT_EQ(toSets(a), bruteSets(points, points, 0.0203f, nullptr, true)) << frame;
  }
}

TEST(UniformGridSearch, QueryGroupsCoverEveryNeighbourOnce) {
  // Another point set (queries inside, on the edge of and far outside the
  // points' box), the points themselves, and points far apart (cells clamped at
  // the lattice's edge: the per-query boxes): every query is in one group, its
  // ranges hold every brute-force neighbour, and the place coordinates are the
  // points'.
  auto points = damBreakWithDroplets(0.01f, 18, 12, 10, 40, 21);
  auto others = uniformPoints(6000, 0.3f, 22);
  others.emplace_back(-5, -5, -5);
  others.emplace_back(0.0f, 0.0f, -0.015f);
  auto far = points;
  far.emplace_back(1e5f, 0.0f, 0.0f);
  struct Case {
    const std::vector<Vec3r>* points;
    const std::vector<Vec3r>* queries;
  };
  for (const Case& c : {Case{&points, &others}, Case{&points, &points}, Case{&far, &others}}) {
    search::UniformGridSearch grid;
    grid.build(c.points->data(), c.points->size(), 0.0203f);
    ASSERT_EQ(grid.pointCount(), c.points->size());
    const Sets expected = bruteSets(*c.points, *c.queries, 0.0203f, nullptr, false);
    std::vector<std::vector<std::uint32_t>> found(c.queries->size());
    std::vector<int> calls(c.queries->size(), 0);
    std::mutex mutex;
    grid.forEachQueryGroup(c.queries->data(), c.queries->size(),
                           [&](const std::uint32_t* group, std::uint32_t size,
                               const search::UniformGridSearch::PlaceRange* ranges, std::uint32_t rangeCount) {
                             std::lock_guard<std::mutex> lock(mutex);
                             for (std::uint32_t r = 0; r < rangeCount; ++r) {
                               ASSERT_LT(ranges[r].begin, ranges[r].end);
                               ASSERT_LE(ranges[r].end, c.points->size());
                               if (r > 0) {
                                 ASSERT_LE(ranges[r - 1].end, ranges[r].begin);
                               }
                             }
                             for (std::uint32_t k = 0; k < size; ++k) {
                               const std::uint32_t q = group[k];
                               if (k > 0) {
                                 ASSERT_LT(group[k - 1], q);
                               }
                               ++calls[q];
                               const Vec3r& x = (*c.queries)[q];
                               for (std::uint32_t r = 0; r < rangeCount; ++r)
                                 for (std::uint32_t place = ranges[r].begin; place < ranges[r].end; ++place) {
                                   const Vec3r p(grid.placeX()[place], grid.placeY()[place], grid.placeZ()[place]);
                                   const std::uint32_t j = grid.placeOrder()[place];
                                   ASSERT_EQ(p, (*c.points)[j]);
                                   if (squaredDistance(x, p) <= 0.0203f * 0.0203f) found[q].push_back(j);
                                 }
                             }
                           });
    std::size_t total = 0;
    for (std::size_t q = 0; q < c.queries->size(); ++q) {
      ASSERT_EQ(calls[q], 1) << q;
      std::sort(found[q].begin(), found[q].end());
      ASSERT_EQ(found[q], expected[q]) << q;
      total += found[q].size();
    }
    EXPECT_GT(total, c.queries->size());
  }
}

TEST(UniformGridSearch, ZOrderIsAPermutationSortedAlongTheCurve) {
  const auto points = uniformPoints(5000, 2.0f, 11);
  search::UniformGridSearch grid;
  grid.build(points.data(), points.size(), 0.1f);
  const auto order = grid.zOrder();
  ASSERT_EQ(order.size(), points.size());
  std::vector<char> seen(points.size(), 0);
  for (std::size_t index : order) {
    ASSERT_LT(index, points.size());
    ASSERT_FALSE(seen[index]);
    seen[index] = 1;
  }
  // Cell keys ascend along the order.
  const Real cell = grid.cellSize();
  auto key = [&](const Vec3r& p) {
    return search::mortonEncode(std::uint32_t(std::floor(p.x() / cell)), std::uint32_t(std::floor(p.y() / cell)),
                                std::uint32_t(std::floor(p.z() / cell)));
  };
  for (std::size_t k = 1; k < order.size(); ++k)
    ASSERT_LE(key(points[order[k - 1]]), key(points[order[k]])) << k;
}

TEST(UniformGridSearch, ZOrderPermutationKeepsTheNeighbourRelation) {
  // Reordering particles along the curve changes indices, not the neighbour relation.
  auto points = damBreakWithDroplets(0.01f, 12, 10, 10, 30, 14);
  std::reverse(points.begin(), points.end());
  const auto order = zOrderPermutation(points.data(), points.size(), 0.0203f);
  ASSERT_EQ(order.size(), points.size());
  std::vector<Vec3r> sorted(points.size());
  for (std::size_t k = 0; k < order.size(); ++k) sorted[k] = points[order[k]];
  const Sets before = bruteSets(points, points, 0.0203f, nullptr, true);
  auto grid = makeNeighborSearch("grid");
  NeighborLists lists;
  grid->findNeighbors(sorted.data(), sorted.size(), 0.0203f, lists);
  const Sets after = toSets(lists);
  for (std::size_t k = 0; k < order.size(); ++k) {
    std::vector<std::uint32_t> mapped;
    for (std::uint32_t j : after[k]) mapped.push_back(static_cast<std::uint32_t>(order[j]));
    std::sort(mapped.begin(), mapped.end());
    ASSERT_EQ(mapped, before[order[k]]) << k;
  }
}

TEST(MortonCode, EncodeDecodeRoundTrip) {
  EXPECT_EQ(search::mortonEncode(1, 0, 0), 1u);
  EXPECT_EQ(search::mortonEncode(0, 1, 0), 2u);
  EXPECT_EQ(search::mortonEncode(0, 0, 1), 4u);
  EXPECT_EQ(search::mortonEncode(3, 0, 0), 9u);
  std::mt19937 rng(12);
  for (int t = 0; t < 1000; ++t) {
    const std::uint32_t x = rng() & search::kMortonMaxCoord, y = rng() & search::kMortonMaxCoord,
                        z = rng() & search::kMortonMaxCoord;
    std::uint32_t a, b, c;
    search::mortonDecode(search::mortonEncode(x, y, z), a, b, c);
    ASSERT_EQ(a, x);
    ASSERT_EQ(b, y);
    ASSERT_EQ(c, z);
  }
}

TEST(CellKeys, EveryPathKeysEveryPointAsTheLatticeFloorDoes) {
  // Points inside, on and across the lattice's bounds: exact cell borders, just
  // below them, negative, beyond the last coordinate, infinite and NaN.
  const double origin[3] = {-0.5, 0.25, 1.0};
  const double inverseCell = 1.0 / 0.0205;
  std::mt19937 rng(31);
  std::uniform_real_distribution<Real> u(-2.0f, 3.0f);
  std::vector<Vec3r> points;
  for (int i = 0; i < 997; ++i) points.emplace_back(u(rng), u(rng), u(rng));
  const Real special[] = {-0.5f,
                          0.25f,
                          1.0f,
                          std::nextafter(-0.5f, -1.0f),
                          Real(-0.5 + 0.0205 * 7),
                          std::nextafter(Real(-0.5 + 0.0205 * 7), -1.0f),
                          -1e30f,
                          1e30f,
                          std::numeric_limits<Real>::infinity(),
                          -std::numeric_limits<Real>::infinity(),
                          std::numeric_limits<Real>::quiet_NaN(),
                          Real(0.0205 * double(search::kMortonMaxCoord) - 0.5),
                          Real(0.0205 * (double(search::kMortonMaxCoord) + 1.5) - 0.5)};
  for (const Real a : special)
    for (const Real b : special) points.emplace_back(a, b, special[(points.size() * 7) % 13]);
  std::vector<std::uint64_t> expected(points.size()), got(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    std::uint32_t c[3];
    for (int a = 0; a < 3; ++a)
      c[a] = search::clampToLattice(search::latticeFloor((double(points[i][a]) - origin[a]) * inverseCell));
    expected[i] = search::mortonEncode(c[0], c[1], c[2]);
  }
  search::cellKeysScalar(points.data(), 0, points.size(), origin, inverseCell, got.data());
  EXPECT_EQ(got, expected);
  search::cellKeys(points.data(), points.size(), origin, inverseCell, got.data());
  EXPECT_EQ(got, expected);
#ifdef CASCADE_CELL_KEYS_AVX512
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq"))
    for (const std::size_t begin : {0, 1, 5}) {
      std::vector<std::uint64_t> simd(points.size(), 0);
      search::cellKeysAvx512(points.data(), begin, points.size() - 3, origin, inverseCell, simd.data());
      for (std::size_t i = begin; i < points.size() - 3; ++i) ASSERT_EQ(simd[i], expected[i]) << i << " at " << points[i].transpose();
      EXPECT_EQ(simd[points.size() - 2], 0u);  // nothing written past the end
    }
#endif
}

/// The tree's nodes partition the points: every inner node's children split
/// its run of places in order, inside its cube; the leaves list every point
/// once. Returns the number of leaves.
static std::size_t expectConsistentTree(const search::OctreeSearch& octree, std::size_t pointCount) {
  std::size_t leaves = 0, listed = 0;
  const std::vector<search::OctreeSearch::Node> nodes = octree.nodes();
  for (const auto& node : nodes) {
    EXPECT_LT(node.begin, node.end);
    if (node.childCount == 0) {
      ++leaves;
      listed += node.end - node.begin;
    } else {
      // Children partition the parent's points, inside the parent's cube.
      std::uint32_t expect = node.begin;
      for (std::uint32_t c = 0; c < node.childCount; ++c) {
        const auto& child = nodes[node.firstChild + c];
        EXPECT_EQ(child.begin, expect);
        expect = child.end;
        EXPECT_GT(child.level, node.level);
        for (int a = 0; a < 3; ++a) {
          EXPECT_GE(child.corner[a], node.corner[a]);
          EXPECT_LE(child.corner[a] + (1u << (21 - child.level)),
                    node.corner[a] + (1u << (21 - node.level)));
        }
      }
      EXPECT_EQ(expect, node.end);
    }
  }
  EXPECT_EQ(listed, pointCount);
  return leaves;
}

TEST(OctreeSearch, LeavesHoldAtMostOneParticleAndCubesContainTheirPoints) {
  auto points = damBreakWithDroplets(0.01f, 10, 10, 10, 40, 13);
  points.push_back(points[17]);  // a duplicate: cannot be split, the pair shares a leaf
  search::OctreeSearch octree;
  octree.build(points.data(), points.size(), 0.02f);
  const std::size_t leaves = expectConsistentTree(octree, points.size());
  EXPECT_EQ(octree.largestLeaf(), 2u);  // only the duplicate pair shares a leaf
  EXPECT_GE(leaves, points.size() - 1);

  search::OctreeSearch bucket(8);
  bucket.build(points.data(), points.size(), 0.02f);
  EXPECT_LE(bucket.largestLeaf(), 8u);
  EXPECT_LT(bucket.nodeCount(), octree.nodeCount());
}

// Above 32768 points the top of the tree is split breadth first and the
// subtrees below in parallel, each into its own region of the kept buffer:
// checked against the grid (itself checked against brute force above), also
// after rebuilds with fewer and then more points (the buffer is reused).
TEST(OctreeSearch, LargeSetsMatchTheGridAcrossRebuilds) {
  const auto points = damBreakWithDroplets(0.01f, 40, 30, 60, 500, 11);  // 72,500 points
  search::OctreeSearch octree;
  search::UniformGridSearch grid;
  for (const std::size_t count : {points.size(), std::size_t(20000), points.size()}) {
    NeighborLists expected, got;
    grid.findNeighbors(points.data(), count, 0.021f, expected);
    octree.findNeighbors(points.data(), count, 0.021f, got);
    ASSERT_EQ(got.size(), count);
    ASSERT_EQ(toSets(got), toSets(expected)) << count << " points";
    EXPECT_EQ(expectConsistentTree(octree, count), count);  // one point per leaf
  }
}

// The scan primitives every search shares (ScanRange.h), on each instruction set
// this processor runs, against the scalar reference: the same neighbours in the
// same order, and a box filter that keeps every point within reach of the box.
namespace {

struct ScanData {
  std::vector<Real> x, y, z;
  std::vector<std::uint32_t> order;
  std::uint32_t count = 0;
};

/// Points around a query box, a few exactly at the reach and one NaN, padded as
/// the searches pad them.
ScanData scanData(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<Real> u(-0.75f, 1.75f);
  ScanData d;
  for (int i = 0; i < 300; ++i) {
    d.x.push_back(u(rng));
    d.y.push_back(u(rng));
    d.z.push_back(u(rng));
  }
  // The box is [0, 1]^3, the reach 0.5: points exactly at it along an axis.
  for (const Real offset : {-0.5f, 1.5f}) {
    d.x.push_back(offset), d.y.push_back(0.5f), d.z.push_back(0.25f);
    d.x.push_back(0.5f), d.y.push_back(offset), d.z.push_back(1.0f);
    d.x.push_back(0.0f), d.y.push_back(0.75f), d.z.push_back(offset);
  }
  d.x.push_back(std::nanf("")), d.y.push_back(0.5f), d.z.push_back(0.5f);
  d.count = std::uint32_t(d.x.size());
  for (std::uint32_t k = 0; k < d.count; ++k) d.order.push_back(1000 + 7 * k);
  for (std::size_t k = 0; k < search::kScanPadding; ++k) {
    d.x.push_back(std::nanf("")), d.y.push_back(std::nanf("")), d.z.push_back(std::nanf(""));
    d.order.push_back(0xffffffffu);
  }
  return d;
}

template <typename Scan>
std::vector<std::uint32_t> gatherWith(const ScanData& d, std::uint32_t begin, std::uint32_t end, Real reach2,
                                      std::vector<Real>* positions = nullptr) {
  const Real lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
  const std::size_t room = d.count + 2 * search::kScanOverwrite;
  std::vector<Real> bx(room), by(room), bz(room);
  std::vector<std::uint32_t> bi(room);
  const std::uint32_t n = Scan::gatherNear(d.x.data(), d.y.data(), d.z.data(), d.order.data(), begin, end, lo, hi,
                                           reach2, bx.data(), by.data(), bz.data(), bi.data(), 0);
  bi.resize(n);
  if (positions)
    for (std::uint32_t k = 0; k < n; ++k) positions->insert(positions->end(), {bx[k], by[k], bz[k]});
  return bi;
}

template <typename Scan>
std::vector<std::uint32_t> scanWith(const ScanData& d, std::uint32_t begin, std::uint32_t end, const Real q[3],
                                    Real radius2, std::uint32_t exclude) {
  std::vector<std::uint32_t> out(d.count + search::kScanOverwrite);
  out.resize(Scan::scan(d.x.data(), d.y.data(), d.z.data(), d.order.data(), begin, end, q[0], q[1], q[2], radius2,
                        exclude, out.data()));
  return out;
}

template <typename Scan>
std::pair<std::vector<std::uint32_t>, std::vector<std::uint32_t>> scanPairWith(const ScanData& d, std::uint32_t begin,
                                                                               std::uint32_t end, const Real a[3],
                                                                               const Real b[3], Real radius2) {
  const std::size_t room = d.count + search::kScanOverwrite;
  std::vector<std::uint32_t> out(2 * room);
  std::uint32_t na = 0, nb = 0;
  Scan::scanPair(d.x.data(), d.y.data(), d.z.data(), d.order.data(), begin, end, a, b, radius2, d.order[begin],
                 0xffffffffu, out.data(), out.data() + room, na, nb);
  // The second list moved down onto the first, as a pair query joins them.
  Scan::moveDown(out.data() + na, out.data() + room, nb);
  return {std::vector<std::uint32_t>(out.begin(), out.begin() + na),
          std::vector<std::uint32_t>(out.begin() + na, out.begin() + na + nb)};
}

} // namespace

TEST(ListAssembly, ListsInTheirRegionsSpilledOrBothAreTheSameListsInTheSameOrder) {
  // Chunks of uneven size over a shuffled query order; list lengths 0-120, longer in
  // some chunks (dense water beside spray); a list written in one or two parts.
  constexpr std::size_t kQueries = 6000;
  std::vector<std::uint32_t> queryOrder(kQueries);
  std::iota(queryOrder.begin(), queryOrder.end(), 0u);
  std::shuffle(queryOrder.begin(), queryOrder.end(), std::mt19937(5));
  std::vector<std::uint32_t> chunkStart{0};
  std::mt19937 rng(6);
  while (chunkStart.back() < kQueries)
    chunkStart.push_back(std::min<std::uint32_t>(std::uint32_t(kQueries), chunkStart.back() + 1 + rng() % 700));
  std::vector<std::uint32_t> length(kQueries);
  for (std::size_t c = 0; c + 1 < chunkStart.size(); ++c)
    for (std::uint32_t s = chunkStart[c]; s < chunkStart[c + 1]; ++s)
      length[queryOrder[s]] = (c % 3 == 0) ? 60 + rng() % 61 : rng() % 40;
  const auto entry = [](std::uint32_t q, std::uint32_t k) { return q * 2654435761u + k; };
  Sets expected(kQueries);
  std::size_t total = 0;
  for (std::uint32_t q = 0; q < kQueries; ++q) {
    for (std::uint32_t k = 0; k < length[q]; ++k) expected[q].push_back(entry(q, k));
    total += length[q];
  }
  const auto process = [&](std::size_t, std::uint32_t placeBegin, std::uint32_t placeEnd,
                           search::ChunkWriter& writer) {
    for (std::uint32_t s = placeBegin; s < placeEnd; ++s) {
      const std::uint32_t q = queryOrder[s], n = length[q], first = q % 2 ? n / 2 : n;
      std::uint32_t* out = writer.reserve(first);
      for (std::uint32_t k = 0; k < first; ++k) out[k] = entry(q, k);
      // The vector scans store up to 16 entries past what they keep.
      for (std::uint32_t k = first; k < first + 16; ++k) out[k] = 0xdeadbeefu;
      writer.advance(first);
      if (first < n) {  // a second part: the open list moves with it if the region fills
        out = writer.reserve(n - first);
        for (std::uint32_t k = first; k < n; ++k) out[k - first] = entry(q, k);
        writer.advance(n - first);
      }
      writer.finishQuery(q);
    }
  };
  const double mean = double(total) / kQueries;
  // No room (every list spilled), too little room (some spilled), room enough.
  for (double lastMean : {0.0, 0.5 * mean, 0.85 * mean, mean, 4 * mean}) {
    search::ListScratch scratch;
    scratch.meanCount = lastMean;
    NeighborLists lists;
    lists.indices.assign(100, 7u);  // a previous call's entries
    search::assembleLists(kQueries, queryOrder.data(), chunkStart, scratch, lists, process);
    ASSERT_EQ(lists.size(), kQueries) << lastMean;
    EXPECT_EQ(inOrder(lists), expected) << lastMean;
    expectDisjointRows(lists);
    EXPECT_EQ(lists.totalCount(), total) << lastMean;
    EXPECT_EQ(lists.offsets.back(), lists.indices.size()) << lastMean;
    EXPECT_DOUBLE_EQ(scratch.meanCount, mean) << lastMean;
    EXPECT_EQ(lists.order, queryOrder) << lastMean;
    if (lastMean > 3 * mean) {  // nothing spilled: every list lies after the one before it in place order
      for (std::size_t k = 1; k < kQueries; ++k)
        ASSERT_GE(lists.offsets[queryOrder[k]], lists.endOffset(queryOrder[k - 1])) << k;
    }
  }
}

TEST(ListOrder, VisitsEveryListBelowTheLimitOnceWhateverTheLayout) {
  auto points = damBreakWithDroplets(0.01f, 16, 16, 16, 20, 21);
  std::shuffle(points.begin(), points.end(), std::mt19937(22));  // lists far from index order
  search::UniformGridSearch grid;
  NeighborLists lists;
  grid.findNeighbors(points.data(), points.size(), 0.0203f, lists);
  ASSERT_EQ(lists.order.size(), points.size());
  std::vector<std::uint32_t> sorted = lists.order;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t k = 0; k < sorted.size(); ++k) ASSERT_EQ(sorted[k], k);  // a permutation
  NeighborLists packed;
  BruteForceSearch brute;
  brute.findNeighbors(points.data(), points.size(), 0.0203f, packed);
  for (const NeighborLists* layout : {&lists, &packed}) {
    const std::size_t limit = points.size() - 37;  // ghosts past the owned particles are skipped
    std::vector<std::atomic<int>> visits(points.size());
    forEachInListOrder(*layout, limit, 64, [&](std::size_t i) { visits[i].fetch_add(1); });
    for (std::size_t i = 0; i < points.size(); ++i) ASSERT_EQ(visits[i].load(), i < limit ? 1 : 0) << i;
  }
}

TEST(ScanRange, BoxFilterKeepsExactlyThePointsWithinReachOfTheBoxOnEveryInstructionSet) {
  const ScanData d = scanData(21);
  const Real reach2 = 0.25f;
  // Reference by hand: per-axis excess over the box, in the filter's order of operations.
  // Positions are fetched by place below, from the index (1000 + 7 place).
  std::vector<std::uint32_t> expected;
  for (std::uint32_t k = 0; k < d.count; ++k) {
    const Real p[3] = {d.x[k], d.y[k], d.z[k]};
    Real e[3];
    for (int a = 0; a < 3; ++a) e[a] = std::max(std::max(Real(0) - p[a], p[a] - Real(1)), Real(0));
    // (The NaN point is kept: a scan never matches it.)
    if (!((e[0] * e[0] + e[1] * e[1]) + e[2] * e[2] > reach2)) expected.push_back(d.order[k]);
  }
  ASSERT_GT(expected.size(), 50u);
  ASSERT_LT(expected.size(), std::size_t(d.count) - 50);
  // The six points exactly at the reach are kept (and the NaN).
  EXPECT_EQ(std::count_if(expected.begin(), expected.end(), [&](std::uint32_t i) { return i >= d.order[300]; }), 7);
  const auto sameBits = [](const std::vector<Real>& u, const std::vector<Real>& v) {
    return u.size() == v.size() && (u.empty() || std::memcmp(u.data(), v.data(), u.size() * sizeof(Real)) == 0);
  };

  // Every start and end within the run (the vector paths' tails), and the
  // positions carried with the indices.
  for (std::uint32_t begin : {0u, 1u, 7u, 15u, 16u, 17u})
    for (std::uint32_t end : {begin, begin + 1, begin + 9, begin + 33, d.count}) {
      std::vector<std::uint32_t> part;
      for (const std::uint32_t i : expected)
        if (i >= d.order[begin] && (end == begin || i < d.order[begin] + 7 * (end - begin))) part.push_back(i);
      if (end == begin) part.clear();
      std::vector<Real> positions;
      const auto baseline = gatherWith<search::ScanBaseline>(d, begin, end, reach2, &positions);
      ASSERT_EQ(baseline, part) << begin << ".." << end;
      std::vector<Real> carried;
      for (const std::uint32_t i : baseline) {
        const std::uint32_t place = (i - 1000) / 7;
        carried.insert(carried.end(), {d.x[place], d.y[place], d.z[place]});
      }
      ASSERT_TRUE(sameBits(positions, carried));
#ifdef CASCADE_SCAN_X86
      if (search::searchUsesAvx2()) {
        std::vector<Real> simd;
        EXPECT_EQ(gatherWith<search::ScanAvx2>(d, begin, end, reach2, &simd), baseline) << begin << ".." << end;
        EXPECT_TRUE(sameBits(simd, positions));
      }
      if (__builtin_cpu_supports("avx512f")) {
        std::vector<Real> simd;
        EXPECT_EQ(gatherWith<search::ScanAvx512>(d, begin, end, reach2, &simd), baseline) << begin << ".." << end;
        EXPECT_TRUE(sameBits(simd, positions));
      }
#endif
    }
}

TEST(ScanRange, ScansAgreeInSetAndOrderOnEveryInstructionSet) {
  const ScanData d = scanData(22);
  const Real a[3] = {0.5f, 0.25f, 1.0f}, b[3] = {1.0f, 0.75f, 0.0f};
  const Real radius2 = 0.36f;
  for (std::uint32_t begin : {0u, 3u, 16u})
    for (std::uint32_t end : {begin + 1, begin + 15, begin + 16, begin + 41, d.count}) {
      // Reference: squaredDistance() point by point, the exclusion by index.
      std::vector<std::uint32_t> expectedA, expectedB;
      for (std::uint32_t k = begin; k < end; ++k) {
        const Vec3r p(d.x[k], d.y[k], d.z[k]);
        if (squaredDistance(Vec3r(a[0], a[1], a[2]), p) <= radius2 && k != begin) expectedA.push_back(d.order[k]);
        if (squaredDistance(Vec3r(b[0], b[1], b[2]), p) <= radius2) expectedB.push_back(d.order[k]);
      }
      const auto baseline = scanPairWith<search::ScanBaseline>(d, begin, end, a, b, radius2);
      ASSERT_EQ(baseline.first, expectedA) << begin << ".." << end;
      ASSERT_EQ(baseline.second, expectedB) << begin << ".." << end;
      ASSERT_EQ(scanWith<search::ScanBaseline>(d, begin, end, a, radius2, d.order[begin]), expectedA);
#ifdef CASCADE_SCAN_X86
      if (search::searchUsesAvx2()) {
        EXPECT_EQ((scanPairWith<search::ScanAvx2>(d, begin, end, a, b, radius2)), baseline);
        EXPECT_EQ(scanWith<search::ScanAvx2>(d, begin, end, a, radius2, d.order[begin]), expectedA);
      }
      if (__builtin_cpu_supports("avx512f")) {
        EXPECT_EQ((scanPairWith<search::ScanAvx512>(d, begin, end, a, b, radius2)), baseline);
        EXPECT_EQ(scanWith<search::ScanAvx512>(d, begin, end, a, radius2, d.order[begin]), expectedA);
      }
#endif
    }
}
