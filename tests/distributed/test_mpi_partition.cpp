// MpiSlabPartition under mpirun (ctest runs this binary with mpirun -np 3): migration,
// ghosts, refreshes, gathers and reductions, each checked against what every rank
// can compute alone from the same starting particles.
#include "distributed/MpiSlabPartition.h"

#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <random>
#include <set>
#include <sstream>

using namespace cascade;
using namespace cascade::distributed;

namespace {

int worldRank() {
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  return rank;
}
int worldSize() {
  int size = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  return size;
}

/// The same random particles on every rank (ids 0..n-1), x in [0, 1].
Particles randomParticles(std::size_t n, unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<float> unit(0.f, 1.f);
  Particles all;
  for (std::size_t i = 0; i < n; ++i) {
    all.add(Vec3r(unit(random), Real(0.2) * unit(random), Real(0.2) * unit(random)),
            Vec3r(unit(random), unit(random), unit(random)), ParticleId(i));
    all.density.back() = Real(1000) + Real(i);
    all.pressure.back() = Real(2) * Real(i);
  }
  return all;
}

Particles ownedPart(const Particles& all, const DomainPartition& partition) {
  Particles owned;
  for (std::size_t i = 0; i < all.size(); ++i)
    if (partition.owns(all.position[i])) owned.append(all, i);
  return owned;
}

std::set<ParticleId> idsOf(const Particles& particles, std::size_t from = 0) {
  return std::set<ParticleId>(particles.id.begin() + long(from), particles.id.end());
}

const Vec3r kLo(0, 0, 0), kHi(1, Real(0.2), Real(0.2)), kGravity(0, 0, Real(-9.81));

} // namespace

TEST(MpiSlabPartition, AParticleCrossingTwoRanksInOneStepGoesStraightToItsOwner) {
  ASSERT_EQ(worldSize(), 3);
  MpiSlabPartition partition(MPI_COMM_WORLD);
  partition.setFirstCuts(0, {Real(0.1), Real(0.2)});
  Particles all;
  for (int k = 0; k < 3; ++k) all.add(Vec3r(Real(0.05) + Real(0.1) * Real(k), 0, 0), Vec3r(Real(k), 0, 0), ParticleId(k));
  partition.start(all, Real(0.01), kLo, kHi, kGravity);
  Particles mine = ownedPart(all, partition);
  ASSERT_EQ(mine.size(), 1u);
  ASSERT_EQ(mine.id[0], ParticleId(worldRank()));
  if (worldRank() == 0) {
    mine.position[0].x() = Real(0.27);  // from slab 0 over slab 1 into slab 2
    mine.density[0] = Real(1234);
  }
  partition.migrate(mine);
  const std::set<ParticleId> expected[3] = {{}, {1}, {0, 2}};
  EXPECT_EQ(idsOf(mine), expected[worldRank()]);
  for (std::size_t i = 0; i < mine.size(); ++i)
    if (mine.id[i] == 0) {
      EXPECT_EQ(mine.density[i], Real(1234));
      EXPECT_EQ(mine.velocity[i].x(), Real(0));
    }
  EXPECT_EQ(partition.maxOverRanks(double(partition.statistics().migrated)), 1.0);
}

TEST(MpiSlabPartition, GhostsAreExactlyTheOtherRanksParticlesWithinTheHalo) {
  MpiSlabPartition partition(MPI_COMM_WORLD);
  const Particles all = randomParticles(3000, 17);
  partition.start(all, Real(0.01), kLo, kHi, kGravity);
  Particles mine = ownedPart(all, partition);
  const std::size_t owned = mine.size();
  const Real halo = Real(0.04);
  partition.addGhosts(mine, halo);
  // Expected: every particle another rank owns whose halo reaches this rank's slab.
  std::set<ParticleId> expected;
  const SlabDecomposition& slabs = partition.slabs();
  for (std::size_t i = 0; i < all.size(); ++i) {
    const Real x = all.position[i].x();
    if (slabs.ownerOf(x) == worldRank()) continue;
    int first = 0, last = 0;
    slabs.ranksWithin(x, halo, first, last);
    if (worldRank() >= first && worldRank() <= last) expected.insert(all.id[i]);
  }
  EXPECT_EQ(mine.size() - owned, expected.size());  // no particle twice
  EXPECT_EQ(idsOf(mine, owned), expected);
  EXPECT_GT(expected.size(), 50u);
  // A ghost arrives with its owner's state.
  for (std::size_t i = owned; i < mine.size(); ++i) {
    const ParticleId id = mine.id[i];
    EXPECT_EQ(mine.position[i], all.position[id]);
    EXPECT_EQ(mine.pressure[i], all.pressure[id]);
  }

  // Refreshing copies the owners' new values into the ghosts.
  std::vector<Real> values(mine.size(), Real(-1));
  std::vector<Vec3r> vectors(mine.size(), Vec3r::Constant(-1));
  for (std::size_t i = 0; i < owned; ++i) {
    values[i] = Real(3) * Real(mine.id[i]);
    vectors[i] = Vec3r(Real(mine.id[i]), Real(worldRank()), 0);
  }
  partition.refreshGhosts(values.data(), owned);
  partition.refreshGhosts(vectors.data(), owned);
  for (std::size_t i = owned; i < mine.size(); ++i) {
    EXPECT_EQ(values[i], Real(3) * Real(mine.id[i]));
    EXPECT_EQ(vectors[i].x(), Real(mine.id[i]));
    EXPECT_EQ(int(vectors[i].y()), slabs.ownerOf(mine.position[i].x()));
  }
}

TEST(MpiSlabPartition, GatherGivesRankZeroEveryParticleOnceInIdOrder) {
  MpiSlabPartition partition(MPI_COMM_WORLD);
  const Particles all = randomParticles(1000, 5);
  partition.start(all, Real(0.01), kLo, kHi, kGravity);
  const Particles gathered = partition.gatherToFirst(ownedPart(all, partition));
  if (worldRank() != 0) {
    EXPECT_TRUE(gathered.empty());
    return;
  }
  ASSERT_EQ(gathered.size(), all.size());
  for (std::size_t i = 0; i < all.size(); ++i) {
    EXPECT_EQ(gathered.id[i], all.id[i]);
    EXPECT_EQ(gathered.position[i], all.position[i]);
    EXPECT_EQ(gathered.velocity[i], all.velocity[i]);
    EXPECT_EQ(gathered.density[i], all.density[i]);
  }
}

TEST(MpiSlabPartition, ReductionsAreTheSameOnEveryRankInRankOrder) {
  MpiSlabPartition partition(MPI_COMM_WORLD);
  // Values whose floating-point sum depends on the order: rank order is 1e16 + 1 - 1e16.
  const double values[3] = {1e16, 1.0, -1e16};
  double sum = values[worldRank()];
  partition.sumOverRanks(&sum, 1);
  EXPECT_EQ(sum, (1e16 + 1.0) + -1e16);
  EXPECT_EQ(partition.maxOverRanks(double(worldRank()) * 2.5), 5.0);
  const std::string local = worldRank() == 0 ? "" : "rank " + std::to_string(worldRank()) + " unstable";
  EXPECT_EQ(partition.firstMessage(local), "rank 1 unstable");
  EXPECT_EQ(partition.firstMessage(""), "");
}

TEST(MpiSlabPartition, ShareDriftingMoreThanTenPercentRebalances) {
  std::ostringstream log;
  MpiSlabPartition partition(MPI_COMM_WORLD, &log);
  const Particles all = randomParticles(3000, 23);
  partition.start(all, Real(0.01), kLo, kHi, kGravity);
  Particles mine = ownedPart(all, partition);
  // The water runs to the far end: x in [0.8, 1].
  for (Vec3r& p : mine.position) p.x() = Real(0.8) + Real(0.2) * p.x();
  partition.migrate(mine);
  EXPECT_EQ(partition.statistics().rebalances, 1u);
  std::uint64_t count = mine.size(), counts[3];
  MPI_Allgather(&count, 1, MPI_UINT64_T, counts, 1, MPI_UINT64_T, MPI_COMM_WORLD);
  EXPECT_EQ(counts[0] + counts[1] + counts[2], 3000u);
  for (std::uint64_t c : counts) EXPECT_NEAR(double(c), 1000.0, 100.0);
  for (std::size_t i = 0; i < mine.size(); ++i) EXPECT_TRUE(partition.owns(mine.position[i]));
  if (worldRank() == 0) {
    EXPECT_NE(log.str().find("(rebalanced)"), std::string::npos) << log.str();
  }
  // Balanced now: the next migration moves nothing and keeps the cuts.
  const std::uint64_t migrated = partition.statistics().migrated;
  partition.migrate(mine);
  EXPECT_EQ(partition.statistics().rebalances, 1u);
  EXPECT_EQ(partition.statistics().migrated, migrated);
}

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  ::testing::InitGoogleTest(&argc, argv);
  if (worldRank() != 0) {  // one rank reports; the others' failures still fail the run
    auto& listeners = ::testing::UnitTest::GetInstance()->listeners();
    delete listeners.Release(listeners.default_result_printer());
  }
  const int result = RUN_ALL_TESTS();
  int worst = result;
  MPI_Allreduce(&result, &worst, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  MPI_Finalize();
  return worst;
}
