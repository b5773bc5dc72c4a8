// DFSPH in a tall, narrow water column (the tank's floor pressure and
// largest compression grew with the column's height in particles).
//
// A quasi-2-D column (symmetry planes front and back, walls elsewhere) of
// `layers` particle layers settles from the lattice at rest density. Over the
// last 0.1 s, sampled every step: the floor pressure (Probes.h pressureAt, the
// probe of `cascade bench accuracy`) against rho g H, both its time mean and its
// step-to-step spread; the floor's mean pressure, as the walls' vertical force on the
// water over its weight; the largest compression max(rho / rho_0 - 1) of any
// particle; the mean compression (the solver's tolerance); and the RMS speed.
// Before the fix (unrelaxed Jacobi sweeps of the one-sided density solve) the
// 36-layer column's floor pressure swung by +-45 % of rho g H from step to step,
// the largest compression reached 1 % and the water moved at 1.2 cm/s RMS.
#include "libsph/boundary/BoxBoundary.h"
#include "libsph/probes/Probes.h"
#include "libsph/solver/Simulation.h"
#include "libsph/solver/TimeStepDFSPH.h"

#include "TestEnvironment.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>

using namespace cascade;

namespace {

struct ColumnResult {
  double pressureMean = 0, pressureSpread = 0;  // floor pressure / (rho g H): mean and standard deviation over steps
  double maxCompression = 0, meanCompression = 0, rmsSpeed = 0, iterations = 0;
  double support = 0;  // the walls' vertical force on the water over its weight, time mean
};

// twoLevel: solver.preconditioner two_level (the default) or jacobi, each with its default
// per-particle bound (TimeStepDFSPH.cpp); the tests without it hold the Jacobi solve, which
// MPI ranks use.
ColumnResult settleColumn(int layers, int across, double endTime, bool twoLevel = false) {
  const double spacing = 0.003175;  // `cascade bench accuracy` at a/18
  const double width = across * spacing, depth = 4 * spacing, height = layers * spacing;
  SimulationSettings settings;
  settings.fluid.spacing = Real(spacing);
  settings.fluid.viscosity = Real(1.0e-3);
  settings.solver.type = "dfsph";
  settings.solver.cflFactor = Real(0.5);
  settings.boundary.slip = MirrorSlip::LaminarWallShear;
  settings.solver.twoLevelPreconditioner = twoLevel;
  settings.solver.particleToleranceShare =
      Real(cascade::test::envOr("CASCADE_COLUMN_PARTICLE_SHARE", double(settings.solver.particleToleranceShare)));
  Simulation sim(settings);
  const std::size_t tank = sim.addBoundary(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(Real(width), Real(depth), Real(2 * height)), false, 2));
  sim.addFluidBox(Vec3r(0, 0, 0), Vec3r(Real(width), Real(depth), Real(height)));
  const double restDensity = settings.fluid.restDensity;
  const double expected = restDensity * kStandardGravity * height;
  const Vec3r floorPoint(Real(0.5 * width), Real(0.5 * depth), 0);
  ColumnResult r;
  double sum = 0, sum2 = 0, speed2 = 0, iterations = 0;
  int samples = 0;
  // Study knobs: CASCADE_COLUMN_END (s) runs longer; CASCADE_COLUMN_PARTICLE_SHARE sets
  // SolverSettings::particleToleranceShare; CASCADE_TEST_VERBOSE prints the floor
  // pressure's mean over every 0.1 s from 1 s on (how much a window's mean wanders).
  endTime = cascade::test::envOr("CASCADE_COLUMN_END", endTime);
  const bool verbose = std::getenv("CASCADE_TEST_VERBOSE") != nullptr;
  double windowSum = 0, windowEnd = 1.1;
  int windowSamples = 0;
  while (sim.time() < endTime) {
    sim.step();
    const bool inWindow = verbose && sim.time() >= windowEnd - 0.1, last = sim.time() >= endTime - 0.1;
    if (!inWindow && !last) continue;
    const Particles& p = sim.particles();
    const double floorPressure = pressureAt(p, floorPoint, sim.supportRadius(), settings.solver.gravity) / expected;
    if (inWindow) {
      windowSum += floorPressure;
      ++windowSamples;
      if (sim.time() >= windowEnd) {
        std::cout << "[dfsph column] " << layers << " layers, floor pressure / rho g H over " << windowEnd - 0.1 << "-"
                  << windowEnd << " s: " << windowSum / windowSamples << "\n";
        windowSum = 0;
        windowSamples = 0;
        windowEnd += 0.1;
      }
    }
    if (!last) continue;
    sum += floorPressure;
    sum2 += floorPressure * floorPressure;
    double compression = 0, v2 = 0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      const double c = double(p.density[i]) / restDensity - 1.0;
      compression += std::max(c, 0.0);
      r.maxCompression = std::max(r.maxCompression, c);
      v2 += double(p.velocity[i].squaredNorm());
    }
    r.meanCompression += compression / double(p.size());
    speed2 += v2 / double(p.size());
    iterations += dynamic_cast<const TimeStepDFSPH&>(sim.timeStep()).lastStatistics().densityIterations;
    r.support += -sim.exchangedForce(tank).z() / (double(sim.particleMass()) * double(p.size()) * kStandardGravity);
    ++samples;
  }
  r.pressureMean = sum / samples;
  r.pressureSpread = std::sqrt(std::max(0.0, sum2 / samples - r.pressureMean * r.pressureMean));
  r.meanCompression /= samples;
  r.rmsSpeed = std::sqrt(speed2 / samples);
  r.iterations = iterations / samples;
  r.support /= samples;
  std::cout << "[dfsph column] " << layers << " layers x " << across << (twoLevel ? ", two-level" : "") << ": floor pressure / rho g H " << r.pressureMean
            << " (spread " << r.pressureSpread << "), compression mean " << 100 * r.meanCompression << " % max "
            << 100 * r.maxCompression << " %, RMS speed " << r.rmsSpeed << " m/s, " << r.iterations
            << " density iterations per step; walls carry " << r.support << " of the weight\n";
  return r;
}

} // namespace

// 36 layers (the bench tank at a/18), 12 particles across: a few seconds. Measured
// before the fix: floor pressure 0.98 (spread 0.41), largest compression 1.0 %, RMS speed
// 1.2 cm/s; after: 1.000 (spread 0.011), 0.126 %, 3.4 mm/s. (8 across settles to a floor
// reading of 1.04 with the fix, steady, 0.4 mm/s: the probe's kernel average over that
// column's settled lattice; 4, 12 and 18 across read 1.000-1.004.)
#ifndef CASCADE_DFSPH_COLUMN_LONG
namespace {
void expectThirtySixLayersAtRest(const ColumnResult& r) {
  EXPECT_NEAR(r.pressureMean, 1.0, 0.02);          // time mean of the floor probe
  EXPECT_NEAR(r.support, 1.0, 0.005);              // the floor's mean pressure: the walls carry the weight
  EXPECT_LT(r.pressureSpread, 0.05);               // step to step (was 0.45)
  EXPECT_LT(r.maxCompression, 0.005);              // largest compression (was 1 %)
  EXPECT_LE(r.meanCompression, 0.0005 * 1.05);     // the solver's average tolerance
  EXPECT_LT(r.rmsSpeed, 0.005 * std::sqrt(kStandardGravity * 36 * 0.003175));  // at rest (was 1.1 % of sqrt(g H))
}
} // namespace

TEST(DFSPHColumn, ThirtySixLayersHoldHydrostaticPressureStepByStep) {
  expectThirtySixLayersAtRest(settleColumn(36, 12, 0.5));
}

// The two-level preconditioner (CoarseCorrection.h) on the same column: the same checks
// hold; the coarse cells take the column's deep, smooth modes, which Jacobi-preconditioned
// CG converges in O(depth) products, and which the Jacobi solve's tight per-particle bound
// is there to force (measured with that bound: 15.3 products a step with Jacobi, 5.8 with
// two levels; 200 layers 76.6 and 3.2: docs/dfsph-deep-water.md, "Two levels").
TEST(DFSPHColumn, TwoLevelPreconditionerHoldsTheColumnInFewerProducts) {
  const ColumnResult jacobi = settleColumn(36, 12, 0.5);
  const ColumnResult r = settleColumn(36, 12, 0.5, true);
  expectThirtySixLayersAtRest(r);
  EXPECT_LT(2 * r.iterations, jacobi.iterations);  // products per step over the last 0.1 s
}
#else
// 72 layers (the bench tank at a/36) and 200 (a pool a body falls into; the target:
// at rest after 2 s, RMS speed below 1 % of sqrt(g H), bottom pressure within 1 % of
// rho g H), label long. Both failed before docs/dfsph-deep-water.md's fix: relaxed Jacobi sweeps that stopped on
// the mean compression (diluted by depth: a missing share of the hydrostatic support shows
// in the floor layer only), and a wall layer that the stiffness of its own mirror images
// sets ringing once omega dt > 2 (kappa ~ g H grows with depth). Fixed by the bound-
// constrained CG solve with a per-particle residual bound and the time-step bound on the
// stiffness (TimeStepDFSPH.cpp, kMaxResidualShare and kStiffnessStepFactor).
TEST(DFSPHColumn, SeventyTwoLayersHoldHydrostaticPressureStepByStep) {
  const ColumnResult r = settleColumn(72, 12, 0.8);
  EXPECT_NEAR(r.pressureMean, 1.0, 0.02);
  EXPECT_NEAR(r.support, 1.0, 0.005);
  EXPECT_LT(r.pressureSpread, 0.1);
  EXPECT_LT(r.maxCompression, 0.01);
  EXPECT_LE(r.meanCompression, 0.0005 * 1.05);
  EXPECT_LT(r.rmsSpeed, 0.01 * std::sqrt(kStandardGravity * 72 * 0.003175));
}

TEST(DFSPHColumn, TwoHundredLayersComeToRest) {
  const ColumnResult r = settleColumn(200, 12, 2.0);
  // The floor's mean pressure (the walls' vertical force over the floor's area) within
  // 1 % of rho g H, the target; the point probe within 2 %: its kernel average depends on
  // how the resting lattice settled (1.0096 and 1.0134, steady, from two solves that meet
  // the same tolerance: docs/dfsph-deep-water.md, "What it costs").
  EXPECT_NEAR(r.support, 1.0, 0.01);
  EXPECT_NEAR(r.pressureMean, 1.0, 0.02);
  EXPECT_LT(r.maxCompression, 0.01);
  EXPECT_LE(r.meanCompression, 0.0005 * 1.05);
  EXPECT_LT(r.rmsSpeed, 0.01 * std::sqrt(kStandardGravity * 200 * 0.003175));
}

TEST(DFSPHColumn, TwoHundredLayersComeToRestWithTwoLevels) {
  const ColumnResult r = settleColumn(200, 12, 2.0, true);
  EXPECT_NEAR(r.support, 1.0, 0.01);
  EXPECT_NEAR(r.pressureMean, 1.0, 0.02);
  EXPECT_LT(r.maxCompression, 0.01);
  EXPECT_LE(r.meanCompression, 0.0005 * 1.05);
  EXPECT_LT(r.rmsSpeed, 0.01 * std::sqrt(kStandardGravity * 200 * 0.003175));
  EXPECT_LT(r.iterations, 20);  // Jacobi: about 80 products a step
}
#endif
