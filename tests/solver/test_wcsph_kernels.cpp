// WCSPH kernel pairs (SolverSettings::kernels) and pressure forces: each pair's
// density is normalised on the rest lattice, and the AVX2 pair loops compute
// the same terms as the scalar fallback.
#include "SolverTestScenes.h"

#include "libsph/solver/TimeStepWCSPH.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

namespace cascade::test {

namespace {

const KernelPair kPairs[] = {KernelPair::Mueller2003, KernelPair::CubicSpline, KernelPair::WendlandC2};

std::string pairName(KernelPair pair) {
  switch (pair) {
    case KernelPair::Mueller2003: return "mueller2003";
    case KernelPair::CubicSpline: return "cubic_spline";
    case KernelPair::WendlandC2: return "wendland_c2";
    case KernelPair::Automatic: return "auto";
  }
  return "?";
}

/// Restores the vector pair loops when a test ends (also on failure).
struct VectorLoopsGuard {
  ~VectorLoopsGuard() { wcsph::allowVectorPairLoops(true); }
};

} // namespace

// A closed box filled with the rest lattice of the fluid spacing, no gravity:
// every particle (the wall layers completed by their mirror images) has rho_0
// (to float rounding), so the pressure is zero and nothing moves: a density
// error of 1e-4 would give ~1e-3 m/s after the first step (c = 10 m/s here),
// rounding gives ~1e-6.
TEST(WcsphKernels, RestLatticeHasRestDensityForEveryPair) {
  for (const KernelPair pair : kPairs) {
    SimulationSettings settings;
    settings.fluid.spacing = Real(0.01);
    settings.solver.kernels = pair;
    settings.solver.gravity = Vec3r::Zero();
    settings.solver.expectedSpeed = Real(1);
    Simulation sim(settings);
    const Real side = Real(0.08);
    sim.addBoundary(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(side, side, side), /*closedTop=*/true));
    sim.addFluidBox(Vec3r(0, 0, 0), Vec3r(side, side, side));
    sim.step();
    Real worstDensity = 0, worstSpeed = 0;
    for (std::size_t i = 0; i < sim.particles().size(); ++i) {
      worstDensity = std::max(worstDensity, std::abs(sim.particles().density[i] / Real(1000) - Real(1)));
      worstSpeed = std::max(worstSpeed, sim.particles().velocity[i].norm());
    }
    EXPECT_LT(worstDensity, 1e-4) << pairName(pair);
    EXPECT_LT(worstSpeed, 1e-5) << pairName(pair);
  }
}

// The same dam break, 40 steps with the AVX2 pair loops and with the scalar
// ones, for every kernel pair and pressure force: the sums differ only in the
// order of float additions, so the particles stay within 1e-5 m (a spacing is
// 5.7e-3 m) and the densities within 1e-4 relative.
TEST(WcsphKernels, VectorAndScalarPairLoopsAgree) {
  VectorLoopsGuard guard;
  if (!wcsph::allowVectorPairLoops(true)) GTEST_SKIP() << "no AVX2 on this processor";
  for (const KernelPair pair : kPairs)
    for (const PressureForce force : {PressureForce::Hamiltonian, PressureForce::Symmetric}) {
      std::vector<Vec3r> positions[2];
      std::vector<Real> densities[2];
      for (int scalar = 0; scalar < 2; ++scalar) {
        wcsph::allowVectorPairLoops(scalar == 0);
        SimulationSettings settings = damBreakSettings(kMartinMoyceA / 10);
        settings.solver.kernels = pair;
        settings.solver.pressureForce = force;
        auto sim = makeDamBreak(settings);
        for (int step = 0; step < 40; ++step) sim->step();
        positions[scalar] = sim->particles().position;
        densities[scalar] = sim->particles().density;
      }
      ASSERT_EQ(positions[0].size(), positions[1].size());
      Real worstPosition = 0, worstDensity = 0;
      for (std::size_t i = 0; i < positions[0].size(); ++i) {
        worstPosition = std::max(worstPosition, (positions[0][i] - positions[1][i]).norm());
        worstDensity = std::max(worstDensity, std::abs(densities[0][i] / densities[1][i] - Real(1)));
      }
      EXPECT_LT(worstPosition, 1e-5) << pairName(pair) << " force " << int(force);
      EXPECT_LT(worstDensity, 1e-4) << pairName(pair) << " force " << int(force);
    }
}

} // namespace cascade::test
