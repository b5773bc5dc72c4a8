// Conservation (validation): mass is exact; a free blob with no walls
// keeps its linear momentum in zero gravity (pairwise forces cancel, SEED (5)
// and (6) in their symmetric forms), and under gravity alone its momentum
// grows by M g t.
#include "SolverTestScenes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>

namespace cascade::test {

namespace {

/// A compressed blob (0.9 spacing) with random velocities about a drift, so
/// that pressure, viscosity and artificial viscosity all act.
std::unique_ptr<Simulation> makeBlob(const Vec3r& gravity) {
  SimulationSettings settings;
  settings.fluid.spacing = Real(0.01);
  settings.fluid.viscosity = Real(0.5);
  settings.solver.gravity = gravity;
  settings.solver.stiffness = Real(400);  // c = 20 m/s
  auto sim = std::make_unique<Simulation>(settings);
  std::mt19937 random(7);
  std::uniform_real_distribution<float> jitter(-0.2f, 0.2f);
  const Vec3r drift(1.0f, 0.5f, -0.25f);
  for (int z = 0; z < 12; ++z)
    for (int y = 0; y < 12; ++y)
      for (int x = 0; x < 12; ++x)
        sim->addParticle(Vec3r(x, y, z) * Real(0.009),
                         drift + Vec3r(jitter(random), jitter(random), jitter(random)));
  return sim;
}

Vec3d momentum(const Simulation& sim) {
  Vec3d total = Vec3d::Zero();
  for (const Vec3r& v : sim.particles().velocity) total += v.cast<double>();
  return total * double(sim.particleMass());
}

} // namespace

TEST(Conservation, MassIsExactInTheDamBreak) {
  auto sim = makeDamBreak(damBreakSettings(kMartinMoyceA / 10));
  const std::size_t count = sim->particles().size();
  const double mass = sim->particleMass() * double(count);
  sim->advanceTo(0.2);
  EXPECT_EQ(sim->particles().size(), count);
  EXPECT_EQ(sim->particleMass() * double(sim->particles().size()), mass);
  EXPECT_EQ(sim->removedCount(), 0u);
  // Ids are a permutation of the initial ones (reordering keeps every particle).
  std::vector<char> seen(count, 0);
  for (ParticleId id : sim->particles().id) {
    ASSERT_LT(id, count);
    EXPECT_FALSE(seen[id]);
    seen[id] = 1;
  }
}

TEST(Conservation, FreeBlobKeepsMomentumInZeroGravity) {
  auto sim = makeBlob(Vec3r::Zero());
  const Vec3d initial = momentum(*sim);
  double worst = 0;
  for (int step = 0; step < 300; ++step) {
    sim->step();
    worst = std::max(worst, (momentum(*sim) - initial).norm() / initial.norm());
  }
  // The blob did deform: pressure pushed it apart.
  Real spread = 0;
  for (const Vec3r& v : sim->particles().velocity) spread = std::max(spread, (v - Vec3r(1.0f, 0.5f, -0.25f)).norm());
  std::cout << "zero gravity: worst relative momentum drift " << worst << " over 300 steps (t = " << sim->time()
            << " s), largest velocity deviation " << spread << " m/s\n";
  EXPECT_LT(worst, 1e-5);
}

TEST(Conservation, FreeBlobMomentumGrowsByMgtUnderGravity) {
  const Vec3r g(0, 0, -kStandardGravity);
  auto sim = makeBlob(g);
  const Vec3d initial = momentum(*sim);
  const double totalMass = sim->particleMass() * double(sim->particles().size());
  double worst = 0;
  for (int step = 0; step < 300; ++step) {
    sim->step();
    const Vec3d expected = initial + totalMass * g.cast<double>() * sim->time();
    worst = std::max(worst, (momentum(*sim) - expected).norm() / expected.norm());
  }
  std::cout << "gravity: worst relative deviation from P0 + M g t " << worst << " (t = " << sim->time() << " s)\n";
  EXPECT_LT(worst, 1e-5);
}

} // namespace cascade::test
