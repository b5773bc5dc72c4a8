// The slab decomposition of distributed/ (no MPI): ownership, halo membership,
// balanced cuts, and the canonical neighbour order that makes every rank count
// give the same sums.
#include "distributed/SlabDecomposition.h"
#include "libsph/search/UniformGridSearch.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>

using namespace cascade;
using namespace cascade::distributed;

TEST(SlabDecomposition, EveryCoordinateHasOneOwnerAndHalfOpenSlabs) {
  SlabDecomposition slabs;
  slabs.cuts = {Real(0.1), Real(0.25), Real(0.4)};
  EXPECT_EQ(slabs.rankCount(), 4);
  EXPECT_EQ(slabs.ownerOf(Real(-5)), 0);
  EXPECT_EQ(slabs.ownerOf(std::nextafter(Real(0.1), Real(0))), 0);
  EXPECT_EQ(slabs.ownerOf(Real(0.1)), 1);  // a cut belongs to the slab above it
  EXPECT_EQ(slabs.ownerOf(Real(0.3)), 2);
  EXPECT_EQ(slabs.ownerOf(Real(0.4)), 3);
  EXPECT_EQ(slabs.ownerOf(Real(99)), 3);
}

TEST(SlabDecomposition, RanksWithinAHaloAreExactlyTheSlabsItReaches) {
  SlabDecomposition slabs;
  slabs.cuts = {Real(0.1), Real(0.12), Real(0.13), Real(0.5)};  // thin slabs: one halo spans several
  const Real halo = Real(0.02);
  std::mt19937 random(7);
  std::uniform_real_distribution<float> coordinate(-0.1f, 0.7f);
  for (int k = 0; k < 5000; ++k) {
    const Real c = coordinate(random);
    int first = 0, last = 0;
    slabs.ranksWithin(c, halo, first, last);
    for (int r = 0; r < slabs.rankCount(); ++r) {
      const double lo = r == 0 ? -1e30 : double(slabs.cuts[std::size_t(r - 1)]);
      const double hi = r == slabs.rankCount() - 1 ? 1e30 : double(slabs.cuts[std::size_t(r)]);
      // Slab [lo, hi) meets [c - halo, c + halo] (the float comparisons of ranksWithin).
      const bool reaches = Real(c - halo) < Real(hi) && Real(lo) <= Real(c + halo);
      EXPECT_EQ(reaches, r >= first && r <= last) << "c " << c << " rank " << r;
    }
  }
}

TEST(SlabDecomposition, BalancedCutsGiveEveryRankTheSameCount) {
  std::mt19937 random(3);
  std::uniform_real_distribution<float> coordinate(0.f, 2.f);
  std::vector<Real> coordinates(10007);
  for (Real& c : coordinates) c = coordinate(random);
  for (int ranks : {2, 3, 7}) {
    SlabDecomposition slabs;
    slabs.cuts = balancedCuts(coordinates, ranks);
    ASSERT_EQ(slabs.rankCount(), ranks);
    std::vector<std::size_t> counts(std::size_t(ranks), 0);
    for (Real c : coordinates) ++counts[std::size_t(slabs.ownerOf(c))];
    for (std::size_t count : counts) {
      EXPECT_GE(count, coordinates.size() / std::size_t(ranks) - 1);
      EXPECT_LE(count, coordinates.size() / std::size_t(ranks) + 1);
    }
  }
  // A lattice plane stays in one slab: 4 planes of 100 particles over 2 ranks.
  std::vector<Real> planes;
  for (int p = 0; p < 4; ++p) planes.insert(planes.end(), 100, Real(0.01) * Real(p));
  SlabDecomposition slabs;
  slabs.cuts = balancedCuts(planes, 2);
  EXPECT_GT(slabs.cuts[0], Real(0.01));
  EXPECT_LT(slabs.cuts[0], Real(0.02));
}

TEST(SlabDecomposition, HistogramCutsBalanceToWithinOneBin) {
  std::mt19937 random(5);
  std::normal_distribution<double> coordinate(1.0, 0.2);  // uneven: a dam break's column
  const Real lo = 0, hi = 2;
  const std::size_t binCount = 4096;
  std::vector<std::uint64_t> bins(binCount, 0);
  std::vector<Real> coordinates(50000);
  for (Real& c : coordinates) {
    c = Real(std::clamp(coordinate(random), 0.0, 2.0));
    ++bins[histogramBin(c, lo, hi, binCount)];
  }
  const std::uint64_t fullest = *std::max_element(bins.begin(), bins.end());
  for (int ranks : {2, 3, 5}) {
    SlabDecomposition slabs;
    slabs.cuts = balancedCutsFromHistogram(bins, lo, hi, ranks);
    std::vector<std::uint64_t> counts(std::size_t(ranks), 0);
    for (Real c : coordinates) ++counts[std::size_t(slabs.ownerOf(c))];
    for (std::uint64_t count : counts)
      EXPECT_LE(std::llabs(static_cast<long long>(count) - static_cast<long long>(coordinates.size()) / ranks),
                static_cast<long long>(fullest))
          << ranks << " ranks";
    EXPECT_FALSE(unbalanced(counts, 0.1));
  }
  EXPECT_TRUE(unbalanced({100, 80}, 0.1));   // 100 > 1.1 x 90
  EXPECT_FALSE(unbalanced({98, 82}, 0.1));   // 98 < 99 and 82 > 81
  EXPECT_TRUE(unbalanced({107, 107, 86}, 0.1));  // 86 < 90, though 107 < 110
  EXPECT_FALSE(unbalanced({0, 0}, 0.1));         // no fluid yet
}

TEST(SlabDecomposition, SlabsRunAlongTheLongestHorizontalAxis) {
  const Vec3r gravity(0, 0, Real(-9.81));
  EXPECT_EQ(slabAxis(Vec3r(0, 0, 0), Vec3r(4, 1, 10), gravity), 0);  // tall: still horizontal
  EXPECT_EQ(slabAxis(Vec3r(0, 0, 0), Vec3r(1, 3, 2), gravity), 1);
  EXPECT_EQ(slabAxis(Vec3r(0, 0, 0), Vec3r(1, 3, 2), Vec3r(0, Real(-9.81), 0)), 2);
}

// What makes an MPI bake bit-identical to one rank: a query's list, in order, depends
// only on the points within its radius, not on which other points the rank holds or
// where it stores them.
TEST(CanonicalNeighborOrder, ListsOfAPartEqualTheWholesInOrder) {
  std::mt19937 random(11);
  std::uniform_real_distribution<float> unit(0.f, 1.f);
  const std::size_t n = 6000;
  std::vector<Vec3r> points(n);
  for (Vec3r& p : points) p = Vec3r(unit(random), Real(0.5) * unit(random), Real(0.5) * unit(random));
  std::vector<ParticleId> ids(n);
  std::iota(ids.begin(), ids.end(), 0u);
  std::shuffle(ids.begin(), ids.end(), random);
  const Real h = Real(0.05), cut = Real(0.5);
  const Vec3r anchor(Real(-0.2), Real(-0.2), Real(-0.2));

  search::UniformGridSearch whole;
  ASSERT_TRUE(whole.setCanonicalOrder(ids.data(), anchor));
  NeighborLists wholeLists;
  whole.findNeighbors(points.data(), n, h, wholeLists);

  // A rank's view: its points (x < cut) in a shuffled order, then the ghosts (within h).
  std::vector<std::size_t> owned, ghosts;
  for (std::size_t i = 0; i < n; ++i) (points[i].x() < cut ? owned : ghosts).push_back(i);
  std::shuffle(owned.begin(), owned.end(), random);
  ghosts.erase(std::remove_if(ghosts.begin(), ghosts.end(), [&](std::size_t i) { return points[i].x() >= cut + h; }),
               ghosts.end());
  std::vector<std::size_t> local = owned;
  local.insert(local.end(), ghosts.begin(), ghosts.end());
  std::vector<Vec3r> localPoints;
  std::vector<ParticleId> localIds;
  for (std::size_t i : local) localPoints.push_back(points[i]), localIds.push_back(ids[i]);
  search::UniformGridSearch part;
  ASSERT_TRUE(part.setCanonicalOrder(localIds.data(), anchor));
  NeighborLists partLists;
  part.findNeighbors(localPoints.data(), localPoints.size(), h, partLists);

  std::size_t compared = 0;
  for (std::size_t k = 0; k < owned.size(); ++k) {
    const std::size_t i = owned[k];
    std::vector<ParticleId> expected, got;
    for (const std::uint32_t* j = wholeLists.begin(i); j != wholeLists.end(i); ++j) expected.push_back(ids[*j]);
    for (const std::uint32_t* j = partLists.begin(k); j != partLists.end(k); ++j) got.push_back(localIds[*j]);
    ASSERT_EQ(got, expected) << "point " << i;
    compared += got.size();
  }
  EXPECT_GT(compared, 10 * owned.size());
}
