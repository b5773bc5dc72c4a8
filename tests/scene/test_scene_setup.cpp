// Scene set-up (SceneSetup.h): the depth of the starting water in particle
// layers, and the warning for dfsph scenes deeper than DFSPH holds still
// (kDfsphStillWaterLayers; README, Solvers and their limits).
#include "libsph/scene/SceneSetup.h"
#include "libsph/solver/TimeStepDFSPH.h"

#include <gtest/gtest.h>

#include <sstream>
#include <string>

using namespace cascade;
using namespace cascade::scene;

namespace {

/// A narrow column `height` m tall on a 1 cm lattice in a tank.
Scene column(double height, const std::string& solver) {
  Scene scene;
  scene.fluid.spacing = 0.01;
  FluidBlock block;
  block.box = {{0, 0, 0}, {0.05, 0.03, height}};
  scene.fluid.blocks = {block};
  scene.boundaries.tank = Box{{0, 0, 0}, {0.05, 0.03, height + 0.1}};
  scene.solver.type = solver;
  return scene;
}

std::string setUpLog(const Scene& scene) {
  Simulation simulation(simulationSettings(scene));
  std::ostringstream log;
  setUpSimulation(scene, simulation, &log);
  return log.str();
}

} // namespace

TEST(SceneSetup, DeepestFluidLayersCountsTheLatticeAlongGravity) {
  Scene scene = column(0.9, "dfsph");
  EXPECT_EQ(deepestFluidLayers(scene), 90);
  scene.gravity = {-9.81, 0, 0};  // along x the block is 5 spacings deep
  EXPECT_EQ(deepestFluidLayers(scene), 5);
  scene.gravity = {0, 0, 0};
  EXPECT_EQ(deepestFluidLayers(scene), 0);
  scene.gravity = {0, 0, -9.81};
  FluidBlock low;
  low.box = {{0, 0, 0}, {0.05, 0.03, 0.2}};
  scene.fluid.blocks.push_back(low);
  EXPECT_EQ(deepestFluidLayers(scene), 90);  // the deepest block
}

TEST(SceneSetup, WarnsWhenDfsphWaterIsDeeperThanItHoldsStill) {
  const int limit = kDfsphStillWaterLayers;
  const std::string deep = setUpLog(column(0.01 * (limit + 10), "dfsph"));
  EXPECT_NE(deep.find("warning: a fluid block stacks " + std::to_string(limit + 10) + " particle layers"),
            std::string::npos)
      << deep;
  EXPECT_NE(deep.find("solver.type=wcsph"), std::string::npos);
  EXPECT_EQ(setUpLog(column(0.01 * limit, "dfsph")).find("warning"), std::string::npos);
  EXPECT_EQ(setUpLog(column(0.01 * (limit + 10), "wcsph")).find("warning"), std::string::npos);
}

TEST(SceneSetup, WarnsWhenADfsphCflFactorIsAboveItsCap) {
  Scene scene = column(0.1, "dfsph");
  scene.solver.cfl = 1.0;
  const std::string log = setUpLog(scene);
  EXPECT_NE(log.find("warning: solver.cfl 1 is above the 0.5 DFSPH holds"), std::string::npos) << log;
  scene.solver.cfl = double(kDfsphMaxCfl);
  EXPECT_EQ(setUpLog(scene).find("warning"), std::string::npos);
  scene.solver.type = "wcsph";
  scene.solver.cfl = 1.0;
  EXPECT_EQ(setUpLog(scene).find("warning"), std::string::npos);
}
