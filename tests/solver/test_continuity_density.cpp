// WCSPH's continuity density (SolverSettings::density = Continuity): its rate is the
// time derivative of the summed density, SEED (4), with the mirror images included.
#include "SolverTestScenes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <map>
#include <sstream>

namespace cascade::test {

namespace {

/// Densities by particle id.
std::map<ParticleId, double> densitiesById(const Simulation& sim) {
  std::map<ParticleId, double> byId;
  for (std::size_t i = 0; i < sim.particles().size(); ++i) byId[sim.particles().id[i]] = sim.particles().density[i];
  return byId;
}

} // namespace

// A dam break 60 steps in (water moving along the floor, against the back wall and
// the slab's symmetry planes: box mirrors and their corner products), then one step of
// 1e-5 s from the same state with each density: the continuity step's change,
// dt sum_j m (v_i - v_j) . grad W_ij over fluid and mirror images, equals the change of
// the summed density between the two steps' positions, to O(dt^2) and float rounding.
TEST(ContinuityDensity, RateIsTheDerivativeOfTheSummedDensityWithMirrors) {
  SimulationSettings settings = damBreakSettings(kMartinMoyceA / 12);
  auto warm = makeDamBreak(settings);
  for (int step = 0; step < 60; ++step) warm->step();
  std::stringstream checkpoint;
  warm->save(checkpoint);

  settings.solver.maxTimeStep = Real(1e-5);
  settings.solver.minTimeStep = Real(1e-7);
  // Summation: one step computes rho(x_0), the next rho(x_1).
  auto summed = makeDamBreak(settings);
  checkpoint.seekg(0);
  summed->restore(checkpoint);
  summed->step();
  const auto before = densitiesById(*summed);
  summed->step();
  const auto after = densitiesById(*summed);
  // Continuity without diffusion: rho(x_0) + dt drho/dt.
  settings.solver.density = DensityEvolution::Continuity;
  settings.solver.densityDiffusion = 0;
  auto integrated = makeDamBreak(settings);
  checkpoint.seekg(0);
  integrated->restore(checkpoint);
  // Start the continuity density from the summed one at x_0.
  auto& rho = integrated->particles().density;
  for (std::size_t i = 0; i < rho.size(); ++i) rho[i] = Real(before.at(integrated->particles().id[i]));
  integrated->step();
  const auto stepped = densitiesById(*integrated);

  double largest = 0, worst = 0;
  int moving = 0;
  for (const auto& [id, rho0] : before) {
    const double summedChange = after.at(id) - rho0, integratedChange = stepped.at(id) - rho0;
    largest = std::max(largest, std::abs(summedChange));
    worst = std::max(worst, std::abs(integratedChange - summedChange));
    if (std::abs(summedChange) > 1e-3) ++moving;
  }
  EXPECT_GT(largest, 0.05);  // kg/m^3 in 1e-5 s: the water is compressing and expanding
  EXPECT_GT(moving, 100);
  EXPECT_LT(worst, 0.02 * largest) << "largest change " << largest;
  if (std::getenv("CASCADE_TEST_VERBOSE"))
    std::cout << "largest change " << largest << " kg/m^3, worst difference " << worst << ", " << moving << " moving\n";
}

} // namespace cascade::test
