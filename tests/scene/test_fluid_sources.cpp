// Fluid sources: block lattices and nozzle emitters.
#include "libsph/scene/FluidSources.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace cascade;
using namespace cascade::scene;

TEST(FluidSources, BlockLatticeFillsTheBoxCentred) {
  FluidBlock block;
  block.box = {{0, 0, 0}, {0.1, 0.05, 0.2}};
  const auto positions = blockPositions(block, 0.01);
  ASSERT_EQ(positions.size(), 10u * 5u * 20u);
  for (const Vec3r& p : positions)
    for (int k = 0; k < 3; ++k) {
      EXPECT_GE(p[k], Real(block.box.min[k] + 0.005 - 1e-6));
      EXPECT_LE(p[k], Real(block.box.max[k] - 0.005 + 1e-6));
    }
}

TEST(FluidSources, DiskEmitterReleasesLayersAtSpeedOverSpacing) {
  Emitter emitter;
  emitter.center = {0, 0, 1};
  emitter.normal = {1, 0, 0};
  emitter.radius = 0.05;
  emitter.speed = 2.0;
  const double spacing = 0.01;
  const auto layer = emitterLayer(emitter, spacing);
  // Disk area / spacing^2 = pi * 25 = 78.5; the lattice count is close to it.
  EXPECT_NEAR(double(layer.size()), M_PI * 25, 8);
  for (const Vec3r& p : layer) EXPECT_NEAR(p.x(), 0, 1e-6);

  EmitterState state;
  Particles particles;
  auto add = [&](const Vec3r& x, const Vec3r& v) { particles.add(x, v, ParticleId(particles.size())); };
  // Layers at t = 0, 0.005, 0.010, ...: 0.0101 s covers three.
  emitUntil(emitter, layer, spacing, 0.0101, state, add);
  EXPECT_EQ(state.layers, 3);
  EXPECT_EQ(particles.size(), 3 * layer.size());
  // Each layer sits speed * (t - released) downstream: x = 2*(0.0101 - k*0.005).
  EXPECT_NEAR(particles.position.front().x(), 2 * 0.0101, 1e-6);
  EXPECT_NEAR(particles.position.back().x(), 2 * (0.0101 - 0.010), 1e-6);
  EXPECT_NEAR(particles.velocity.back().x(), 2.0, 1e-6);
}

TEST(FluidSources, EmitterStopsAtEndAndMaxCount) {
  Emitter emitter;
  emitter.shape = "rectangle";
  emitter.size = {0.04, 0.02};
  emitter.normal = {0, 0, -1};
  emitter.up = {0, 1, 0};
  emitter.speed = 1;
  emitter.end = 0.05;
  const double spacing = 0.01;
  const auto layer = emitterLayer(emitter, spacing);
  EXPECT_EQ(layer.size(), 8u);
  EmitterState state;
  std::size_t count = 0;
  auto add = [&](const Vec3r&, const Vec3r&) { ++count; };
  emitUntil(emitter, layer, spacing, 1.0, state, add);
  EXPECT_EQ(state.layers, 6);  // t = 0, 0.01, ..., 0.05
  EXPECT_EQ(count, 48u);

  emitter.end = 1e30;
  emitter.maxCount = 20;
  EmitterState limited;
  count = 0;
  emitUntil(emitter, layer, spacing, 1.0, limited, add);
  EXPECT_EQ(count, 20u);
}

TEST(FluidSources, InflowBufferHoldsTheNozzleVelocityOverTheNozzleOnly) {
  // The production bunny's nozzle: a 0.3 x 0.08 m rectangle pointing 15 degrees down.
  Emitter emitter;
  emitter.shape = "rectangle";
  emitter.center = {-1.287, 0.0, 0.303};
  emitter.normal = {0.9659, 0.0, -0.2588};
  emitter.up = {0.2588, 0.0, 0.9659};
  emitter.size = {0.3, 0.08};
  emitter.speed = 1.0;
  emitter.end = 1.2;
  const double spacing = 0.005;
  const Vec3d n = Vec3d(0.9659, 0, -0.2588).normalized(), up = Vec3d(0.2588, 0, 0.9659).normalized();
  const Vec3d c(-1.287, 0.0, 0.303);
  Particles particles;
  const auto at = [&](double along, double across, double height) {
    const Vec3d x = c + along * n + across * Vec3d(0, 1, 0) + height * up;
    particles.add(x.cast<Real>(), Vec3r(-3, 0.5, -1), ParticleId(particles.size()));  // pushed back by the jet
  };
  at(0.0, 0.0, 0.0);               // 0: on the nozzle plane
  at(-0.6 * spacing, 0.14, 0.035); // 1: just behind the plane, near a corner of the nozzle
  at(3.5 * spacing, -0.1, -0.02);  // 2: in the buffer, 3.5 layers out
  at(4.5 * spacing, 0.0, 0.0);     // 3: past the buffer
  at(-1.5 * spacing, 0.0, 0.0);    // 4: behind the nozzle (at the tank wall side)
  at(0.01, 0.16, 0.0);             // 5: beside the nozzle
  at(0.01, 0.0, 0.045);            // 6: above it
  const Vec3r nozzleVelocity = n.cast<Real>();
  EmitterState state;
  EXPECT_EQ(holdInflow(emitter, spacing, 0.5, state, particles), 3u);
  for (int i : {0, 1, 2}) EXPECT_LT((particles.velocity[i] - nozzleVelocity).norm(), 1e-6) << i;
  for (int i : {3, 4, 5, 6}) EXPECT_EQ(particles.velocity[i], Vec3r(-3, 0.5, -1)) << i;
  // Before the start, after the end and once the maximum count is out: nothing held.
  for (Vec3r& v : particles.velocity) v = Vec3r(-3, 0.5, -1);
  EXPECT_EQ(holdInflow(emitter, spacing, 1.3, state, particles), 0u);
  emitter.start = 0.6;
  EXPECT_EQ(holdInflow(emitter, spacing, 0.5, state, particles), 0u);
  emitter.start = 0;
  emitter.maxCount = 100;
  state.emitted = 100;
  EXPECT_EQ(holdInflow(emitter, spacing, 0.5, state, particles), 0u);
  for (const Vec3r& v : particles.velocity) EXPECT_EQ(v, Vec3r(-3, 0.5, -1));
}

TEST(FluidSources, KillBoxesAndDomainFlagParticles) {
  Boundaries boundaries;
  boundaries.domain = Box{{-1, -1, -1}, {1, 1, 1}};
  boundaries.kill.push_back(Box{{0.5, -1, -1}, {1, 1, 1}});
  Particles particles;
  particles.add(Vec3r(0, 0, 0), Vec3r::Zero(), 0);
  particles.add(Vec3r(0.7, 0, 0), Vec3r::Zero(), 1);
  particles.add(Vec3r(0, 0, -2), Vec3r::Zero(), 2);
  std::vector<char> flags;
  EXPECT_EQ(flagLeavingParticles(boundaries, particles, flags), 2u);
  EXPECT_EQ(flags, (std::vector<char>{0, 1, 1}));
}
