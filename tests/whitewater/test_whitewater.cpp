// Whitewater (Ihmsen et al. 2012): potentials, limits, advection of each kind
// against its analytic motion, births, foam lifetime, files and determinism.
#include "WhitewaterTestFluids.h"
#include "TestTempDir.h"

#include "libsph/Errors.h"
#include "libsph/io/Ply.h"
#include "libsph/search/UniformGridSearch.h"
#include "whitewater/DiffuseAdvection.h"
#include "whitewater/FluidSampling.h"
#include "whitewater/Potentials.h"
#include "whitewater/WhitewaterFile.h"
#include "whitewater/WhitewaterSolver.h"

#include <gtest/gtest.h>

#include <numeric>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <random>

using namespace cascade;
using namespace cascade::whitewater;

namespace {

const Vec3r kGravity(0, 0, Real(-9.81));

FluidPotentials potentialsOf(const ParticleFrame& frame, Real h) {
  std::vector<Vec3r> x, v;
  fluidArrays(frame, x, v, "test");
  search::UniformGridSearch grid;
  NeighborLists lists;
  grid.findNeighbors(x.data(), x.size(), h, lists);
  return computePotentials(x, v, lists, h);
}

/// Steps `particles` through `intervals` frame intervals of `dt` over the (frozen) fluid `fluid`.
IntervalStats runOver(WhitewaterSolver& solver, const ParticleFrame& fluid, const std::vector<float>& rates,
                      int intervals, double dt, DiffuseParticles& particles, std::uint32_t& nextId) {
  IntervalStats total;
  ParticleFrame a = fluid;
  for (int k = 0; k < intervals; ++k) {
    ParticleFrame b = test::movedOn(a, dt);
    const FluidInterval interval(a, b, a.time, b.time, "test");
    const IntervalStats stats = solver.advance(interval, rates, k + 1, particles, nextId);
    total.born += stats.born;
    total.dissolved += stats.dissolved;
    total.left += stats.left;
    total.substeps += stats.substeps;
    a = b;
  }
  return total;
}

} // namespace

TEST(Potentials, ClampIsEquationOne) {
  EXPECT_FLOAT_EQ(clampPotential(1.0f, 2, 8), 0.0f);
  EXPECT_FLOAT_EQ(clampPotential(5.0f, 2, 8), 0.5f);
  EXPECT_FLOAT_EQ(clampPotential(20.0f, 2, 8), 1.0f);
}

TEST(Potentials, UniformMotionTrapsNoAirAndConvergingFlowDoes) {
  const Real s = Real(0.01), h = 2 * s;
  // A block moving as one: every v_ij is zero.
  const ParticleFrame uniform = test::latticeFluid({0, 0, 0}, {0.2f, 0.2f, 0.1f}, s, {2, 0, 0});
  const FluidPotentials still = potentialsOf(uniform, h);
  for (float value : still.trappedAir) EXPECT_EQ(value, 0.0f);
  for (float value : still.kineticEnergy) EXPECT_TRUE(value == 2.0f || value == 0.0f);  // |v|^2/2, or a droplet's 0
  // Two halves closing at 2 m/s: air is trapped where they meet, nowhere else.
  ParticleFrame closing = uniform;
  for (std::size_t i = 0; i < closing.size(); ++i)
    closing.velocity[i] = closing.position[i].x() < Real(0.1) ? Vec3r(1, 0, 0) : Vec3r(-1, 0, 0);
  const FluidPotentials meeting = potentialsOf(closing, h);
  float nearSeam = 0, far = 0;
  for (std::size_t i = 0; i < closing.size(); ++i) {
    const Real distance = std::abs(closing.position[i].x() - Real(0.1));
    if (distance < s && closing.position[i].z() > 2 * s && closing.position[i].z() < Real(0.1) - 2 * s)
      nearSeam = std::max(nearSeam, meeting.trappedAir[i]);
    if (distance > 2 * h) far = std::max(far, meeting.trappedAir[i]);
  }
  EXPECT_GT(nearSeam, 1.0f);
  EXPECT_EQ(far, 0.0f);
}

TEST(Potentials, TheTipOfAWedgeRisingAlongItsNormalIsACrestAndAFlatSurfaceIsNot) {
  // A slab and a 60-degree wedge, both rising at 1 m/s (along their top normal).
  // The wedge's tip sees neighbours behind it whose normals turn away from its
  // own, so its curvature sum exceeds the flat surface's (the paper's tau_min 2).
  const Real s = Real(0.01), h = 2 * s, top = Real(0.1);
  const ParticleFrame slab = test::latticeFluid({0, 0, 0}, {0.3f, 0.3f, top}, s, {0, 0, 1});
  ParticleFrame wedge;
  wedge.spacing = s;
  for (std::size_t i = 0; i < slab.size(); ++i) {
    const Vec3r& x = slab.position[i];
    if (std::abs(x.y() - Real(0.155)) <= (top - x.z()) * Real(0.5774) + Real(1e-4)) {
      wedge.position.push_back(x);
      wedge.velocity.push_back(slab.velocity[i]);
      wedge.id.push_back(std::uint32_t(wedge.id.size()));
    }
  }
  // The largest crest potential near the top, away from the ends in x (and the slab's sides).
  const auto topMiddle = [&](const ParticleFrame& frame, const FluidPotentials& p) {
    float value = 0;
    for (std::size_t i = 0; i < frame.size(); ++i) {
      const Vec3r& x = frame.position[i];
      if (x.z() > top - 4 * s && std::abs(x.x() - Real(0.15)) < Real(0.08) && std::abs(x.y() - Real(0.155)) < Real(0.08))
        value = std::max(value, p.waveCrest[i]);
    }
    return value;
  };
  const float flat = topMiddle(slab, potentialsOf(slab, h));
  const float crest = topMiddle(wedge, potentialsOf(wedge, h));
  EXPECT_GT(crest, 1.5f * flat) << "flat " << flat << ", wedge tip " << crest;
  std::printf("crest potential: flat %.3f, wedge tip %.3f\n", double(flat), double(crest));
  // Falling, the same tip is no crest (it moves against its normal).
  ParticleFrame falling = wedge;
  for (Vec3r& v : falling.velocity) v = Vec3r(0, 0, -1);
  EXPECT_EQ(topMiddle(falling, potentialsOf(falling, h)), 0.0f);
}

TEST(Potentials, AutomaticLimitsAreATenthOfTheMeanMaximumToIt) {
  FluidPotentials a, b;
  a.trappedAir = {0, 10, 20};
  b.trappedAir = {0, 40};
  a.waveCrest = {0, 1};
  b.waveCrest = {0, 3};
  a.kineticEnergy = {100};
  b.kineticEnergy = {300};
  PotentialLimits floors;
  floors.trappedAir = {1, 0};
  floors.waveCrest = {2, 0};
  floors.kineticEnergy = {0.5, 0};
  const PotentialLimits limits = limitsFromStatistics({a, b}, floors);
  EXPECT_DOUBLE_EQ(limits.trappedAir[0], 3.0);    // mean of maxima 30
  EXPECT_DOUBLE_EQ(limits.trappedAir[1], 30.0);
  EXPECT_DOUBLE_EQ(limits.waveCrest[0], 2.0);     // 0.2 is below the floor
  EXPECT_DOUBLE_EQ(limits.waveCrest[1], 4.0);     // at least twice the lower limit
  EXPECT_DOUBLE_EQ(limits.kineticEnergy[0], 20.0);
  EXPECT_DOUBLE_EQ(limits.kineticEnergy[1], 200.0);
}

TEST(DiffuseAdvection, RelaxMotionIsExactForAnyStep) {
  // dv/dt = a + k (u - v) in one step and in 1000 steps: the same state.
  const Vec3r u(1, 0, 0), a(0, 0, -9.81f);
  Vec3r x1(0, 0, 0), v1(0, 2, 3), x2 = x1, v2 = v1;
  relaxMotion(x1, v1, u, a, 5.0, 0.3);
  for (int k = 0; k < 1000; ++k) relaxMotion(x2, v2, u, a, 5.0, 0.3 / 1000);
  EXPECT_NEAR((x1 - x2).norm(), 0, 1e-5);
  EXPECT_NEAR((v1 - v2).norm(), 0, 1e-4);
  // The terminal velocity u + a/k.
  Vec3r x3(0, 0, 0), v3(0, 0, 0);
  relaxMotion(x3, v3, u, a, 5.0, 10.0);
  EXPECT_NEAR((v3 - (u + a / 5)).norm(), 0, 1e-5);
}

TEST(FluidSampling, CountsAndWeightedVelocityAreBruteForcesOnEveryProcessorPath) {
  // A jittered block of fluid with a shear flow, sampled at positions inside,
  // on its surface and far away; against the sums over all fluid particles, and
  // the AVX2 and the portable version bit for bit.
  const Real spacing = 0.01f, h = 2 * spacing;
  std::vector<Vec3r> fluid, velocity;
  std::mt19937 rng(31);
  std::uniform_real_distribution<Real> jitter(-0.2f * spacing, 0.2f * spacing);
  for (int k = 0; k < 12; ++k)
    for (int j = 0; j < 10; ++j)
      for (int i = 0; i < 14; ++i) {
        const Vec3r x(i * spacing + jitter(rng), j * spacing + jitter(rng), k * spacing + jitter(rng));
        fluid.push_back(x);
        velocity.emplace_back(x.z() * 10, Real(0.5) - x.x(), Real(0.1) * std::sin(x.y() * 50));
      }
  std::vector<Vec3r> at;
  std::uniform_real_distribution<Real> inside(-0.03f, 0.16f);
  for (int q = 0; q < 3000; ++q) at.emplace_back(inside(rng), inside(rng), inside(rng));
  at.emplace_back(5, 5, 5);
  search::UniformGridSearch grid;
  grid.build(fluid.data(), fluid.size(), h);
  PlaceVelocities places;
  places.gather(grid, velocity);
  std::vector<FluidSample> fast, portable, counts;
  sampleFluid(grid, &places, at.data(), at.size(), h, fast);
  sampleFluid(grid, nullptr, at.data(), at.size(), h, counts);
  ::setenv("CASCADE_NO_AVX2", "1", 1);
  sampleFluid(grid, &places, at.data(), at.size(), h, portable);
  ::unsetenv("CASCADE_NO_AVX2");
  std::size_t withFluid = 0;
  for (std::size_t q = 0; q < at.size(); ++q) {
    std::uint32_t neighbors = 0;
    double weight = 0;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (std::size_t j = 0; j < fluid.size(); ++j) {
      if (squaredDistance(at[q], fluid[j]) > h * h) continue;
      ++neighbors;
      const double w = std::max(0.0, 1.0 - double((at[q] - fluid[j]).norm()) / double(h));
      weight += w;
      sum += w * velocity[j].cast<double>();
    }
    ASSERT_EQ(fast[q].neighbors, neighbors) << q;
    ASSERT_EQ(counts[q].neighbors, neighbors) << q;
    ASSERT_NEAR(fast[q].weight, weight, 1e-5 * (1 + weight)) << q;
    if (weight > 1e-3) {
      ++withFluid;
      ASSERT_LT((fast[q].velocity.cast<double>() - sum / weight).norm(), 1e-5) << q;
    }
    ASSERT_EQ(portable[q].neighbors, fast[q].neighbors) << q;
    ASSERT_EQ(portable[q].weight, fast[q].weight) << q;
    ASSERT_EQ(portable[q].velocity, fast[q].velocity) << q;
  }
  EXPECT_GT(withFluid, at.size() / 3);
}

TEST(WhitewaterSolver, SprayFarFromWaterFollowsTheDragFreeParabola) {
  scene::WhitewaterSettings settings;
  settings.airDrag = 0;
  const Real s = Real(0.01);
  WhitewaterSolver solver(settings, kGravity, s, RemovalBox{});
  // The fluid is a small block far away; the spray particle is thrown at 3 m/s, 45 degrees up.
  const ParticleFrame fluid = test::latticeFluid({10, 10, 0}, {10.05f, 10.05f, 0.05f}, s, {0, 0, 0});
  DiffuseParticles spray;
  const Vec3r x0(0, 0, 1), v0(2.1213f, 0, 2.1213f);
  spray.push_back(x0, v0, 0, 0);
  std::uint32_t nextId = 1;
  const double dt = 1.0 / 30;
  runOver(solver, fluid, std::vector<float>(fluid.size(), 0), 12, dt, spray, nextId);
  ASSERT_EQ(spray.size(), 1u);
  const double t = 12 * dt;
  const Vec3r expected = x0 + Real(t) * v0 + Real(0.5 * t * t) * kGravity;
  const double travelled = (expected - x0).norm();
  EXPECT_LT((spray.position[0] - expected).norm(), 0.01 * travelled);
  EXPECT_NEAR(spray.age[0], t, 1e-5);
}

TEST(WhitewaterSolver, ABubbleInStillWaterRisesAtTheTerminalSpeed) {
  scene::WhitewaterSettings settings;  // buoyancy 2 |g|, drag 40 /s: 0.4905 m/s
  const Real s = Real(0.01);
  WhitewaterSolver solver(settings, kGravity, s, RemovalBox{});
  const ParticleFrame water = test::latticeFluid({0, 0, 0}, {0.2f, 0.2f, 0.5f}, s, {0, 0, 0});
  DiffuseParticles bubble;
  bubble.push_back(Vec3r(0.1f, 0.1f, 0.05f), Vec3r(0, 0, 0), 0, 0);
  std::uint32_t nextId = 1;
  const double dt = 1.0 / 30;
  runOver(solver, water, std::vector<float>(water.size(), 0), 3, dt, bubble, nextId);  // past the relaxation (25 ms)
  const Real z0 = bubble.position[0].z();
  runOver(solver, water, std::vector<float>(water.size(), 0), 6, dt, bubble, nextId);
  const double speed = double(bubble.position[0].z() - z0) / (6 * dt);
  const double terminal = settings.buoyancy * 9.81 / settings.bubbleDrag;
  EXPECT_NEAR(speed, terminal, 0.05 * terminal);
  EXPECT_EQ(solver.classify(bubble, water.position)[0], DiffuseType::Bubble);
}

TEST(WhitewaterSolver, FoamCountDecaysWithTheSetLifetime) {
  scene::WhitewaterSettings settings;
  settings.lifetime = {1.0, 3.0};  // uniform: at t in [1, 3], N (3 - t) / 2 remain
  const Real s = Real(0.01);
  WhitewaterSolver solver(settings, kGravity, s, RemovalBox{});
  const ParticleFrame water = test::latticeFluid({0, 0, 0}, {0.3f, 0.3f, 0.1f}, s, {0, 0, 0});
  DiffuseParticles foam;
  const int n = 4000;
  for (int k = 0; k < n; ++k)  // on the surface, where there are 6 to 20 fluid neighbours
    foam.push_back(Vec3r(0.05f + 0.2f * float(k % 63) / 63, 0.05f + 0.2f * float(k / 63) / 64, 0.1f), Vec3r(0, 0, 0),
                   std::uint32_t(k), 0);
  const std::vector<DiffuseType> types = solver.classify(foam, water.position);
  for (DiffuseType type : types) ASSERT_EQ(type, DiffuseType::Foam);
  std::uint32_t nextId = n;
  const double dt = 1.0 / 30;
  runOver(solver, water, std::vector<float>(water.size(), 0), 30, dt, foam, nextId);  // t = 1
  EXPECT_GT(foam.size(), std::size_t(0.97 * n));
  runOver(solver, water, std::vector<float>(water.size(), 0), 30, dt, foam, nextId);  // t = 2
  EXPECT_NEAR(double(foam.size()), 0.5 * n, 0.1 * 0.5 * n);
  runOver(solver, water, std::vector<float>(water.size(), 0), 31, dt, foam, nextId);  // t > 3
  EXPECT_EQ(foam.size(), 0u);
}

TEST(WhitewaterSolver, BirthsScaleLinearlyWithTheRate) {
  scene::WhitewaterSettings settings;
  const Real s = Real(0.01);
  const ParticleFrame water = test::latticeFluid({0, 0, 0}, {0.2f, 0.2f, 0.1f}, s, {1, 0, 0});
  std::vector<std::size_t> born;
  for (double scale : {0.5, 1.0, 2.0}) {
    WhitewaterSolver solver(settings, kGravity, s, RemovalBox{});
    std::vector<float> rates(water.size());
    for (std::size_t i = 0; i < rates.size(); ++i) rates[i] = float(scale * 30.0 * double(i % 7) / 6);  // 0..30 /s
    DiffuseParticles particles;
    std::uint32_t nextId = 0;
    born.push_back(runOver(solver, water, rates, 3, 1.0 / 30, particles, nextId).born);
    EXPECT_EQ(nextId, born.back());
  }
  EXPECT_NEAR(double(born[1]) / double(born[0]), 2.0, 0.1);
  EXPECT_NEAR(double(born[2]) / double(born[1]), 2.0, 0.1);
}

TEST(WhitewaterSolver, BirthsLieInTheCylinderAroundTheSourcesPath) {
  // Slow enough that the source stays in its cell (the rate field's) over the interval.
  scene::WhitewaterSettings settings;
  settings.substeps = 1;
  const Real s = Real(0.01);
  WhitewaterSolver solver(settings, kGravity, s, RemovalBox{});
  const Real speed = Real(0.1);
  const ParticleFrame water = test::latticeFluid({0, 0, 0}, {0.1f, 0.1f, 0.1f}, s, {speed, 0, 0});
  std::vector<float> rates(water.size(), 0);
  const std::size_t source = water.size() / 2;
  rates[source] = 3000;  // 100 per interval of 1/30 s
  DiffuseParticles particles;
  std::uint32_t nextId = 0;
  runOver(solver, water, rates, 1, 1.0 / 30, particles, nextId);
  ASSERT_GT(particles.size(), 80u);
  const Vec3r x = water.position[source];
  for (std::size_t i = 0; i < particles.size(); ++i) {
    const Vec3r d = particles.position[i] - x;
    EXPECT_GE(d.x(), -1e-6);
    EXPECT_LE(d.x(), speed / 30 + 1e-6);                              // along the path over the step
    EXPECT_LE(std::hypot(double(d.y()), double(d.z())), s / 2 + 1e-6);  // within r_V of it
    EXPECT_EQ(particles.velocity[i], Vec3r(speed, 0, 0));
  }
}

TEST(WhitewaterSolver, ASourceThatStaysInPlaceGivesAnEvenStreamNotAStripeAFrame) {
  // A stream at U = 2 m/s past a place that is a source at every frame (the
  // particles within it then have a rate, as at the foot of a slope). Every
  // particle that passes it gives birth there, at any time, so the whitewater
  // carried off by the stream is even along it. (Rates carried by the particles
  // that sat there at frame times made a cluster per frame, U / 30 s = 6.7 cm
  // apart with 3 cm gaps between.) With no air drag everything born keeps the
  // stream's U along x: x - U t, the place in the stream, is fixed from birth.
  // A source that moves with the stream instead (the same particles hot at
  // every frame) gives birth all along its path, at its own rate.
  scene::WhitewaterSettings settings;
  settings.airDrag = 0;
  const Real s = Real(0.01), speed = Real(2);
  const double frame = 1.0 / 30, zoneLow = 0.3, zoneHigh = 0.32;
  const float rate = 600;
  const ParticleFrame start = test::latticeFluid({-0.6f, 0, 0}, {1.0f, 0.1f, 0.05f}, s, {speed, 0, 0});
  std::vector<std::uint8_t> inZoneAtStart(start.size(), 0);
  for (std::size_t i = 0; i < start.size(); ++i)
    inZoneAtStart[i] = start.position[i].x() >= zoneLow && start.position[i].x() < zoneHigh;
  const int frames = 6;
  for (const bool stays : {true, false}) {
    SCOPED_TRACE(stays ? "a source that stays" : "a source that moves");
    WhitewaterSolver solver(settings, kGravity, s, RemovalBox{});
    const auto ratesAt = [&](const ParticleFrame& f) {
      std::vector<float> rates(f.size(), 0.0f);
      for (std::size_t i = 0; i < f.size(); ++i)
        if (stays ? f.position[i].x() >= zoneLow && f.position[i].x() < zoneHigh : inZoneAtStart[i] != 0)
          rates[i] = rate;
      return rates;
    };
    DiffuseParticles particles;
    std::uint32_t nextId = 0;
    FrameBirthRates atStart, atEnd;
    ParticleFrame a = start;
    for (int k = 0; k < frames; ++k) {
      const ParticleFrame b = test::movedOn(a, frame);
      solver.frameRates(a.position, ratesAt(a), atStart);
      solver.frameRates(b.position, ratesAt(b), atEnd);
      solver.advance(FluidInterval(a, b, a.time, b.time, "test"), atStart, atEnd, k + 1, particles, nextId);
      a = b;
    }
    // Every one of the 100 sources' births over the 6 frames, within their Poisson noise.
    const std::size_t sources = std::size_t(std::count(inZoneAtStart.begin(), inZoneAtStart.end(), 1));
    ASSERT_EQ(sources, 100u);
    const double expected = double(sources) * rate * frames * frame;
    EXPECT_NEAR(double(particles.size()), expected, 4 * std::sqrt(expected) + 0.02 * expected);
    const double end = frames * frame, period = double(speed) * frame;
    if (stays) {
      // Born at the place (within a cell and a sub-step's path), at any time: the
      // places in the stream of frames 2 to 5's births, in bins of a quarter frame.
      const double low = zoneLow - 4.5 * period, high = zoneLow - 1.5 * period;
      std::vector<int> bins(12, 0);
      for (std::size_t i = 0; i < particles.size(); ++i) {
        const double born = double(particles.position[i].x()) - double(speed) * particles.age[i];
        EXPECT_GE(born, zoneLow - double(s) - 1e-4);
        EXPECT_LE(born, zoneHigh + double(s) + double(speed) * frame / 2 + 1e-4);
        const double place = double(particles.position[i].x()) - double(speed) * end;
        if (place >= low && place < high) ++bins[std::size_t((place - low) / (high - low) * 12)];
      }
      const double mean = std::accumulate(bins.begin(), bins.end(), 0.0) / 12;
      for (int count : bins) EXPECT_GT(count, 0.6 * mean) << ::testing::PrintToString(bins);
    } else {
      // Born along the sources' path (it starts at the place and runs U t on): at
      // every stretch of it, in bins of a quarter frame (the first and the last
      // hold the path's ends).
      std::vector<int> bins(4 * frames, 0);
      for (std::size_t i = 0; i < particles.size(); ++i) {
        const double born = double(particles.position[i].x()) - double(speed) * particles.age[i];
        const double travelled = born - zoneLow;  // how far along the path it was born
        if (travelled >= 0 && travelled < frames * period) ++bins[std::size_t(travelled / period * 4)];
      }
      bins.erase(bins.begin());
      bins.pop_back();
      const double mean = std::accumulate(bins.begin(), bins.end(), 0.0) / double(bins.size());
      for (int count : bins) EXPECT_GT(count, 0.6 * mean) << ::testing::PrintToString(bins);
    }
  }
}

TEST(WhitewaterSolver, TheSameInputsGiveTheSameParticlesWhateverTheThreadCount) {
  scene::WhitewaterSettings settings;
  const Real s = Real(0.01);
  ParticleFrame water = test::latticeFluid({0, 0, 0}, {0.2f, 0.2f, 0.1f}, s, {0, 0, 0});
  for (std::size_t i = 0; i < water.size(); ++i) water.velocity[i] = Vec3r(std::sin(Real(i)), std::cos(Real(3 * i)), 1);
  std::vector<float> rates(water.size());
  for (std::size_t i = 0; i < rates.size(); ++i) rates[i] = float(i % 11);
  std::uint64_t sums[2];
  for (int threads : {1, 2}) {
    tbb::global_control control(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
    WhitewaterSolver solver(settings, kGravity, s, RemovalBox{});
    WhitewaterFrame frame;
    runOver(solver, water, rates, 4, 1.0 / 30, frame.particles, frame.nextId);
    frame.type = solver.classify(frame.particles, water.position);
    sums[threads - 1] = whitewaterChecksum(frame);
    EXPECT_GT(frame.particles.size(), 100u);
  }
  EXPECT_EQ(sums[0], sums[1]);
}

TEST(WhitewaterSolver, ParticlesLeavingTheDomainAreRemoved) {
  scene::WhitewaterSettings settings;
  RemovalBox domain;
  domain.min = Vec3r(-1, -1, 0);
  domain.max = Vec3r(1, 1, 2);
  WhitewaterSolver solver(settings, kGravity, 0.01, domain);
  const ParticleFrame fluid = test::latticeFluid({5, 5, 5}, {5.05f, 5.05f, 5.05f}, 0.01f, {0, 0, 0});
  DiffuseParticles spray;
  spray.push_back(Vec3r(0, 0, 0.1f), Vec3r(0, 0, 0), 0, 0);  // falls through the floor at z = 0 in 0.14 s
  spray.push_back(Vec3r(0, 0, 1.5f), Vec3r(0, 0, 0), 1, 0);  // still inside after 0.2 s
  std::uint32_t nextId = 2;
  const IntervalStats stats = runOver(solver, fluid, std::vector<float>(fluid.size(), 0), 6, 1.0 / 30, spray, nextId);
  EXPECT_EQ(stats.left, 1u);
  ASSERT_EQ(spray.size(), 1u);
  EXPECT_EQ(spray.id[0], 1u);
}

TEST(WhitewaterFile, VdbAndPlyRoundTrip) {
  const std::filesystem::path dir = test::freshTempDir("whitewater_file");
  WhitewaterFrame frame;
  frame.spacing = 0.01;
  frame.time = 1.25;
  frame.nextId = 77;
  frame.inputHash = "0123456789abcdef";
  for (int k = 0; k < 500; ++k) {
    frame.particles.push_back(Vec3r(0.001f * float(k), 0.5f - 0.002f * float(k), 0.3f), Vec3r(float(k), -1, 2),
                              std::uint32_t(k * 3), 0.01f * float(k));
    frame.type.push_back(DiffuseType(k % 3));
  }
  const auto path = dir / "whitewater.0001.vdb";
  writeWhitewaterVdb(path, frame);
  const WhitewaterFrame back = readWhitewaterVdb(path);
  EXPECT_EQ(back.nextId, 77u);
  EXPECT_DOUBLE_EQ(back.time, 1.25);
  EXPECT_EQ(back.inputHash, frame.inputHash);
  ASSERT_EQ(back.particles.size(), 500u);
  EXPECT_EQ(back.counts(), frame.counts());
  // Positions to the 16-bit fixed point of a 2-spacing voxel; the rest exact.
  std::vector<std::size_t> byId(1500);
  for (std::size_t i = 0; i < back.particles.size(); ++i) byId[back.particles.id[i]] = i;
  for (std::size_t k = 0; k < 500; ++k) {
    const std::size_t i = byId[frame.particles.id[k]];
    EXPECT_LT((back.particles.position[i] - frame.particles.position[k]).norm(), 0.02 / 65536 * 2);
    EXPECT_EQ(back.particles.velocity[i], frame.particles.velocity[k]);
    EXPECT_EQ(back.particles.age[i], frame.particles.age[k]);
    EXPECT_EQ(back.type[i], frame.type[k]);
  }
  EXPECT_EQ(readWhitewaterHeader(path).inputHash, frame.inputHash);

  const auto ply = dir / "whitewater.0001.ply";
  writeWhitewaterPly(ply, back);
  const ParticleFrame points = readParticleFrame(ply);
  ASSERT_EQ(points.size(), 500u);
  EXPECT_EQ(points.id[7], back.particles.id[7]);
  EXPECT_EQ(points.position[7], back.particles.position[7]);
  EXPECT_EQ(points.velocity[7], back.particles.velocity[7]);
}

TEST(WhitewaterFile, PositionsRoundedAsStoredAreWhatTheFileGivesBack) {
  // Random positions, negative and positive, far and near, on voxel centres and
  // halfway between them: written and read back, each equals its rounding in
  // memory bit for bit (matched by id: reading groups the points by voxel).
  WhitewaterFrame frame;
  frame.spacing = 0.00575;
  const float voxel = float(2 * frame.spacing);
  std::mt19937 rng(41);
  std::uniform_real_distribution<float> wide(-3.0f, 3.0f), unit(0.0f, 1.0f);
  std::uint32_t id = 0;
  for (int i = 0; i < 20000; ++i) {
    Vec3r x(wide(rng), wide(rng), wide(rng));
    if (i % 4 == 1) x = Vec3r(std::round(x.x() / voxel) * voxel, x.y(), x.z());          // on a centre
    if (i % 4 == 2) x = Vec3r(x.x(), (std::round(x.y() / voxel) + 0.5f) * voxel, x.z());  // halfway
    if (i % 4 == 3) x *= 1e-3f * unit(rng);                                               // near 0
    frame.particles.push_back(x, Vec3r::Zero(), id++, 0.0f);
    frame.type.push_back(DiffuseType::Foam);
  }
  frame.particles.push_back(Vec3r::Zero(), Vec3r::Zero(), id++, 0.0f);
  frame.type.push_back(DiffuseType::Foam);
  const std::filesystem::path path = test::freshTempDir("whitewater_rounding") / "whitewater.0001.vdb";
  writeWhitewaterVdb(path, frame);
  const WhitewaterFrame back = readWhitewaterVdb(path);
  WhitewaterFrame rounded = frame;
  roundPositionsAsStored(rounded);
  ASSERT_EQ(back.particles.size(), frame.particles.size());
  std::size_t moved = 0;
  for (std::size_t k = 0; k < back.particles.size(); ++k) {
    const std::uint32_t i = back.particles.id[k];
    ASSERT_EQ(back.particles.position[k], rounded.particles.position[i]) << "id " << i;
    moved += back.particles.position[k] != frame.particles.position[i];
  }
  EXPECT_GT(moved, frame.particles.size() / 2);  // the rounding is real
}

TEST(WhitewaterFile, AForeignOrTruncatedFileIsBadInput) {
  const std::filesystem::path dir = test::freshTempDir("whitewater_bad");
  ParticleFrame particles = test::latticeFluid({0, 0, 0}, {0.05f, 0.05f, 0.05f}, 0.01f, {0, 0, 0});
  writeParticleFrame(dir / "particles.vdb", particles);
  EXPECT_THROW(readWhitewaterVdb(dir / "particles.vdb"), InputError);
  WhitewaterFrame frame;
  frame.spacing = 0.01;
  frame.particles.push_back(Vec3r(0, 0, 0), Vec3r(0, 0, 0), 0, 0);
  frame.type.push_back(DiffuseType::Spray);
  writeWhitewaterVdb(dir / "w.vdb", frame);
  std::filesystem::resize_file(dir / "w.vdb", std::filesystem::file_size(dir / "w.vdb") / 2);
  EXPECT_THROW(readWhitewaterVdb(dir / "w.vdb"), InputError);
}
