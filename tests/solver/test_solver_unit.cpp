// Unit tests of the simulation machinery: equation of state, exact
// checkpoints, instability errors, domain removal, probes, solids mesh.
#include "SolverTestScenes.h"

#include "libsph/Errors.h"
#include "libsph/boundary/PlaneBoundary.h"
#include "libsph/probes/Probes.h"
#include "libsph/solver/EquationOfState.h"

#include <gtest/gtest.h>

#include <cstring>
#include <sstream>

namespace cascade::test {

TEST(EquationOfState, LinearTaitAndClamping) {
  PressureModel linear;
  linear.stiffness = 100;
  linear.clampNegative = false;
  EXPECT_FLOAT_EQ(linear(1010), 1000);  // SEED (10): k (rho - rho0)
  EXPECT_FLOAT_EQ(linear(990), -1000);
  linear.clampNegative = true;
  EXPECT_FLOAT_EQ(linear(990), 0);
  PressureModel tait = linear;
  tait.equation = EquationOfState::Tait;
  tait.clampNegative = false;
  // B ((rho/rho0)^7 - 1), B = rho0 k / 7
  EXPECT_NEAR(tait(1010), 1000.0 * 100 / 7 * (std::pow(1.01, 7) - 1), 0.05);
  // Same slope at rest: dp/drho = k.
  EXPECT_NEAR((tait(1000.01f) - tait(999.99f)) / 0.02, 100, 1.0);
}

// A support factor of 0 (the default) is the solver's own: WCSPH 2.15 spacings, DFSPH 2.
TEST(Simulation, SupportRadiusIsTheSolversOwnUnlessSet) {
  SimulationSettings settings;
  settings.fluid.spacing = Real(0.01);
  EXPECT_FLOAT_EQ(Simulation(settings).supportRadius(), Real(0.0215));
  settings.solver.type = "dfsph";
  EXPECT_FLOAT_EQ(Simulation(settings).supportRadius(), Real(0.02));
  settings.solver.supportRadiusFactor = Real(2.5);
  EXPECT_FLOAT_EQ(Simulation(settings).supportRadius(), Real(0.025));
  settings.solver.supportRadiusFactor = Real(0.5);
  EXPECT_THROW(Simulation{settings}, InputError);
}

TEST(Simulation, RestoredRunIsBitIdenticalToAnUninterruptedOne) {
  const SimulationSettings settings = damBreakSettings(kMartinMoyceA / 10);
  auto reference = makeDamBreak(settings);
  reference->advanceTo(0.05);
  std::stringstream checkpoint;
  reference->save(checkpoint);
  reference->advanceTo(0.12);

  auto resumed = makeDamBreak(settings);  // same set-up, then the saved state
  resumed->restore(checkpoint);
  EXPECT_EQ(resumed->time(), 0.05);
  resumed->advanceTo(0.12);
  const Particles& a = reference->particles();
  const Particles& b = resumed->particles();
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(reference->stepCount(), resumed->stepCount());
  EXPECT_EQ(0, std::memcmp(a.position.data(), b.position.data(), a.size() * sizeof(Vec3r)));
  EXPECT_EQ(0, std::memcmp(a.velocity.data(), b.velocity.data(), a.size() * sizeof(Vec3r)));
  EXPECT_EQ(a.id, b.id);
}

TEST(Simulation, TruncatedOrForeignCheckpointIsAnInputError) {
  auto sim = makeDamBreak(damBreakSettings(kMartinMoyceA / 8));
  sim->step();
  std::stringstream checkpoint;
  sim->save(checkpoint);
  const std::string data = checkpoint.str();
  std::stringstream truncated(data.substr(0, data.size() / 2));
  auto other = makeDamBreak(damBreakSettings(kMartinMoyceA / 8));
  EXPECT_THROW(other->restore(truncated), InputError);
  std::stringstream foreign("not a checkpoint at all");
  EXPECT_THROW(other->restore(foreign), InputError);
  SimulationSettings settings = damBreakSettings(kMartinMoyceA / 8);
  Simulation noBoundaries(settings);
  std::stringstream again(data);
  EXPECT_THROW(noBoundaries.restore(again), InputError);
}

TEST(Simulation, InstabilityNamesParticlePositionAndTime) {
  auto sim = makeDamBreak(damBreakSettings(kMartinMoyceA / 8));
  sim->advanceTo(0.01);
  const std::size_t victim = 5;
  sim->particles().velocity[victim] = Vec3r(1e4f, 0, 0);  // far above anything the scene produces
  const ParticleId id = sim->particles().id[victim];
  try {
    sim->step();
    FAIL() << "no InstabilityError";
  } catch (const InstabilityError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("particle " + std::to_string(id) + " at ("), std::string::npos) << message;
    EXPECT_NE(message.find("t = "), std::string::npos) << message;
  }
  auto nan = makeDamBreak(damBreakSettings(kMartinMoyceA / 8));
  nan->step();
  nan->particles().position[3].x() = std::numeric_limits<Real>::quiet_NaN();
  EXPECT_THROW(nan->step(), InstabilityError);
}

TEST(Simulation, ParticlesLeavingTheDomainAreRemovedAndCounted) {
  SimulationSettings settings;
  settings.fluid.spacing = 0.01f;
  settings.domain.enabled = true;
  settings.domain.min = Vec3r(-1, -1, -0.05f);
  settings.domain.max = Vec3r(1, 1, 1);
  Simulation sim(settings);
  sim.addFluidBox(Vec3r(0, 0, 0), Vec3r(0.03f, 0.03f, 0.03f));  // 27 particles falling freely
  const ParticleId emitted = sim.addParticle(Vec3r(0.5f, 0.5f, 0.5f), Vec3r::Zero());
  EXPECT_EQ(emitted, 27u);
  sim.advanceTo(0.2);  // the block falls ~0.2 m: below -0.05
  EXPECT_EQ(sim.removedCount(), 27u);
  ASSERT_EQ(sim.particles().size(), 1u);
  EXPECT_EQ(sim.particles().id[0], emitted);
  EXPECT_DOUBLE_EQ(sim.time(), 0.2);
}

TEST(Simulation, SolidsMeshHasOneGroupPerBoundary) {
  Simulation sim(damBreakSettings(0.01));
  auto tank = BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(1, 1, 1));
  tank->setName("tank");
  sim.addBoundary(std::move(tank));
  auto slope = PlaneBoundary::rectangle(Vec3r(0.5f, 0.5f, 0.2f), Vec3r(1, 0, -0.2f), Vec3r(0, 1, 0), 0.3f, 0.2f);
  slope->setName("slope");
  sim.addBoundary(std::move(slope));
  const TriangleMesh mesh = sim.solidsMesh();
  ASSERT_EQ(mesh.groups.size(), 2u);
  EXPECT_EQ(mesh.groups[0].name, "tank");
  EXPECT_EQ(mesh.groups[0].end - mesh.groups[0].begin, 10u);  // 5 walls, open top
  EXPECT_EQ(mesh.groups[1].name, "slope");
  EXPECT_EQ(mesh.groups[1].end - mesh.groups[1].begin, 2u);
  EXPECT_EQ(sim.findBoundary("slope"), 1);
  EXPECT_EQ(sim.findBoundary("nope"), -1);
}

TEST(Probes, FrontIgnoresIsolatedDroplets) {
  std::vector<Vec3r> positions;
  for (int z = 0; z < 4; ++z)
    for (int x = 0; x < 10; ++x) positions.emplace_back(0.01f * x, 0, 0.01f * z);
  positions.emplace_back(0.5f, 0, 0);  // a lone droplet far ahead
  EXPECT_NEAR(surgeFront(positions, Vec3r(1, 0, 0), 0.01f), 0.095, 1e-6);
  EXPECT_NEAR(surgeFront(positions, Vec3r(-2, 0, 0), 0.01f), 0.005, 1e-6);
  EXPECT_NEAR(waterHeight(positions, 0.05, 0.0, 0.01f), 0.035, 1e-6);
  EXPECT_TRUE(std::isnan(waterHeight(positions, 0.3, 0.0, 0.01f)));
}

TEST(Probes, PressureAtAWallPointExtrapolatesHydrostatically) {
  Particles particles;
  particles.mass = 1e-3f;
  const Real rho = 1000, g = kStandardGravity, top = 0.1f;
  for (int z = 0; z < 10; ++z)
    for (int y = -3; y <= 3; ++y)
      for (int x = -3; x <= 3; ++x) {
        const Vec3r p(0.01f * x, 0.01f * y, 0.005f + 0.01f * z);
        particles.add(p, Vec3r::Zero(), 0);
        particles.density.back() = rho;
        particles.pressure.back() = rho * g * (top - p.z());
      }
  const double p = pressureAt(particles, Vec3r(0, 0, 0), 0.02f, Vec3r(0, 0, -g));
  EXPECT_NEAR(p, rho * g * top, 1e-3 * rho * g * top);
}

TEST(Probes, ObstacleForceOfTheFluidOnTheFloorIsItsWeight) {
  // A resting column pushes on the tank with its weight (type I and II forces).
  SimulationSettings settings;
  settings.fluid.spacing = 0.01f;
  auto sim = std::make_unique<Simulation>(settings);
  auto tank = BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(0.08f, 0.08f, 0.2f));
  tank->setName("tank");
  sim->addBoundary(std::move(tank));
  sim->addFluidBox(Vec3r(0, 0, 0), Vec3r(0.08f, 0.08f, 0.08f));
  while (sim->time() < 0.4) {
    sim->step();
    for (Vec3r& v : sim->particles().velocity) v *= 0.99f;
  }
  Vec3d mean = Vec3d::Zero();
  const int samples = 200;
  for (int k = 0; k < samples; ++k) {
    sim->step();
    mean += obstacleForce(*sim, "tank") / samples;
  }
  const double weight = sim->particleMass() * double(sim->particles().size()) * kStandardGravity;
  std::cout << "tank force " << mean.transpose() << " N, weight " << weight << " N\n";
  EXPECT_NEAR(mean.z(), -weight, 0.05 * weight);
  EXPECT_NEAR(mean.x(), 0, 0.02 * weight);
  EXPECT_THROW(obstacleForce(*sim, "bunny"), std::invalid_argument);
}

} // namespace cascade::test
