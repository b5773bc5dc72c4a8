// Scene set-up (SceneSetup.h): the depth of the starting water in particle
// layers, and the warning for dfsph scenes deeper than DFSPH is measured to hold
// still (kDfsphStillWaterLayers; docs/dfsph-deep-water.md); the warning for a
// dfsph CFL factor above its cap; block particles inside solids, or within half a
// spacing of an earlier block, left out.
#include "libsph/scene/FluidSources.h"
#include "libsph/scene/SceneSetup.h"
#include "libsph/solver/TimeStepDFSPH.h"
#include "libsph/solver/TimeStepWCSPH.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "TestTempDir.h"

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

TEST(SceneSetup, WarnsWhenDfsphWaterIsDeeperThanMeasured) {
  const int limit = kDfsphStillWaterLayers;
  const std::string deep = setUpLog(column(0.01 * (limit + 10), "dfsph"));
  EXPECT_NE(deep.find("warning: a fluid block stacks " + std::to_string(limit + 10) + " particle layers"),
            std::string::npos)
      << deep;
  EXPECT_NE(deep.find("deeper is untested"), std::string::npos);
  EXPECT_EQ(setUpLog(column(0.01 * limit, "dfsph")).find("warning"), std::string::npos);
  EXPECT_EQ(setUpLog(column(0.01 * (limit + 10), "wcsph")).find("warning"), std::string::npos);
}

// A slab two layers wide at 1 cm: with a support of 3 spacings the nearest image that
// its single reflections and edge products miss (a particle's neighbour one layer over,
// translated by twice the width) lies 3 cm away, at the support's edge; at 3.5 spacings it
// lies inside, and a standing wave there threw its water up by 0.9 spacing in three
// periods (docs/moving-solids.md, "A slab's far wall").
TEST(SceneSetup, WarnsWhenATankIsNarrowerThanTheSupportLessASpacing) {
  Scene scene = column(0.1, "wcsph");
  scene.fluid.blocks[0].box = {{0, 0, 0}, {0.05, 0.02, 0.1}};
  scene.boundaries.tank = Box{{0, 0, 0}, {0.05, 0.02, 0.2}};
  scene.solver.supportFactor = 3;
  EXPECT_EQ(setUpLog(scene).find("warning"), std::string::npos) << setUpLog(scene);
  scene.solver.supportFactor = 3.5;
  const std::string log = setUpLog(scene);
  EXPECT_NE(log.find("warning: the tank is 0.02 m across y, less than the support radius 0.035 m less a spacing"),
            std::string::npos)
      << log;
  EXPECT_EQ(log.find("across x"), std::string::npos);  // 0.05 m: wide enough
}

// WCSPH's continuity density beyond 2.2 spacings of support: still water is unstable
// without the velocity filter (tests/solver/test_standing_wave.cpp, StillWaterForWaves).
TEST(SceneSetup, WarnsWhenContinuityDensityAtAWideSupportHasNoVelocityFilter) {
  Scene scene = column(0.1, "wcsph");
  scene.solver.density = "continuity";
  EXPECT_EQ(setUpLog(scene).find("warning"), std::string::npos) << setUpLog(scene);  // 2.15 spacings
  scene.solver.supportFactor = 3;
  const std::string log = setUpLog(scene);
  EXPECT_NE(log.find("warning: continuity density at solver.support_factor 3 with no solver.velocity_filter"),
            std::string::npos)
      << log;
  scene.solver.velocityFilter = 0.12;
  EXPECT_EQ(setUpLog(scene).find("warning"), std::string::npos) << setUpLog(scene);
  scene.solver.velocityFilter = 0;
  scene.solver.density = "summation";
  EXPECT_EQ(setUpLog(scene).find("warning"), std::string::npos) << setUpLog(scene);
}

TEST(SceneSetup, WarnsWhenACflFactorIsAboveItsSolversCap) {
  Scene scene = column(0.1, "dfsph");
  scene.solver.cfl = 1.0;
  const std::string log = setUpLog(scene);
  EXPECT_NE(log.find("warning: solver.cfl 1 is above the 0.5 dfsph holds"), std::string::npos) << log;
  scene.solver.cfl = double(kDfsphMaxCfl);
  EXPECT_EQ(setUpLog(scene).find("warning"), std::string::npos);
  scene.solver.type = "wcsph";
  scene.solver.cfl = 1.0;
  EXPECT_NE(setUpLog(scene).find("warning: solver.cfl 1 is above the 0.6 wcsph holds"), std::string::npos);
  scene.solver.cfl = double(kWcsphMaxCfl);
  EXPECT_EQ(setUpLog(scene).find("warning"), std::string::npos);
}

TEST(SceneSetup, BlockParticlesInsideSolidsAreLeftOut) {
  Scene scene;
  scene.fluid.spacing = 0.05;
  FluidBlock block;
  block.box = {{0.6, 0, 0}, {1.2, 0.5, 0.5}};  // reaches 0.2 m past the tank's wall x = 1
  scene.fluid.blocks = {block};
  scene.boundaries.tank = Box{{0, 0, 0}, {1, 1, 1}};
  Slope slab;  // a solid box in the block: x 0.7-0.9, y 0.1-0.3, z 0.1-0.2
  slab.name = "slab";
  slab.center = {0.8, 0.2, 0.15};
  slab.size = {0.2, 0.2, 0.1};
  scene.boundaries.slopes = {slab};
  // Expected from the lattice itself: outside the tank, or within the slab.
  std::size_t outside = 0, inSlab = 0;
  const std::vector<Vec3r> lattice = blockPositions(block, scene.fluid.spacing);
  for (const Vec3r& p : lattice) {
    if (p.x() > 1) {
      ++outside;
    } else if (std::abs(p.x() - 0.8) <= 0.1 && std::abs(p.y() - 0.2) <= 0.1 && std::abs(p.z() - 0.15) <= 0.05) {
      ++inSlab;
    }
  }
  ASSERT_GT(outside, 0u);
  ASSERT_GT(inSlab, 0u);
  Simulation simulation(simulationSettings(scene));
  std::ostringstream log;
  setUpSimulation(scene, simulation, &log);
  EXPECT_EQ(simulation.particles().size(), lattice.size() - outside - inSlab);
  for (const Vec3r& p : simulation.particles().position)
    for (std::size_t b = 0; b < simulation.boundaryCount(); ++b) EXPECT_FALSE(simulation.boundary(b).isInside(p));
  EXPECT_NE(log.str().find("fluid block 1: " + std::to_string(outside + inSlab) + " of its " +
                           std::to_string(lattice.size()) + " particles lie inside solids (or within 0.45 spacing of a mesh) and are left out"),
            std::string::npos)
      << log.str();
}

// Two overlapping blocks (an L of water) fill their union once: the second leaves out
// its lattice points within half a spacing of the first box, so no two particles
// start closer than a spacing (overlapping particles stop a WCSPH bake at step 3).
TEST(SceneSetup, OverlappingBlocksFillTheirUnionOnce) {
  Scene scene;
  scene.fluid.spacing = 0.02;
  FluidBlock first, second;
  first.box = {{0, 0, 0}, {0.3, 0.2, 0.2}};
  second.box = {{0.213, 0.05, 0.0}, {0.4, 0.2, 0.45}};  // lattice offset from the first's
  scene.fluid.blocks = {first, second};
  scene.boundaries.tank = Box{{0, 0, 0}, {0.4, 0.2, 1}};
  const std::vector<Vec3r> a = blockPositions(first, 0.02), b = blockPositions(second, 0.02);
  std::size_t kept = 0;
  for (const Vec3r& p : b)
    if (!(p.x() >= -0.01f && p.x() <= 0.31f && p.y() >= -0.01f && p.y() <= 0.21f && p.z() >= -0.01f && p.z() <= 0.21f))
      ++kept;
  ASSERT_LT(kept, b.size());
  Simulation simulation(simulationSettings(scene));
  std::ostringstream log;
  setUpSimulation(scene, simulation, &log);
  const std::vector<Vec3r>& x = simulation.particles().position;
  EXPECT_EQ(x.size(), a.size() + kept);
  double closest = 1;
  for (std::size_t i = 0; i < x.size(); ++i)
    for (std::size_t j = i + 1; j < x.size(); ++j) closest = std::min(closest, double((x[i] - x[j]).norm()));
  EXPECT_GE(closest, 0.02 * (1 - 1e-4));
  EXPECT_NE(log.str().find("fluid block 2: " + std::to_string(b.size() - kept) + " of its " + std::to_string(b.size()) +
                           " particles overlap earlier blocks"),
            std::string::npos)
      << log.str();
}

namespace cascade::scene {

// A mesh in a block: the lattice points inside it and those within 0.45 spacing of its
// surface are left out (a point just outside sat in the r^-13 layer of SEED (11)); those
// half a spacing and more away stay.
TEST(SceneSetup, BlockParticlesNextToAMeshAreLeftOut) {
  const std::filesystem::path dir = cascade::test::freshTempDir("setup_mesh");
  // A cube [0.28, 0.62]^2 x [0.08, 0.42]: the lattice points (k + 0.5) 0.1 of the layers
  // next to its faces lie 0.03 m (0.3 spacing) off them.
  std::ofstream(dir / "cube.obj") << "v 0.28 0.28 0.08\nv 0.62 0.28 0.08\nv 0.28 0.62 0.08\nv 0.62 0.62 0.08\n"
                                     "v 0.28 0.28 0.42\nv 0.62 0.28 0.42\nv 0.28 0.62 0.42\nv 0.62 0.62 0.42\n"
                                     "f 1 3 4\nf 1 4 2\nf 5 6 8\nf 5 8 7\nf 1 2 6\nf 1 6 5\nf 3 7 8\nf 3 8 4\n"
                                     "f 1 5 7\nf 1 7 3\nf 2 4 8\nf 2 8 6\n";
  Scene scene;
  scene.fluid.spacing = 0.1;
  FluidBlock block;
  block.box = {{0, 0, 0}, {0.9, 0.9, 0.5}};
  scene.fluid.blocks = {block};
  scene.boundaries.tank = Box{{0, 0, 0}, {0.9, 0.9, 1}};
  Obstacle cube;
  cube.name = "cube";
  cube.mesh = (dir / "cube.obj").string();
  scene.boundaries.obstacles = {cube};
  // Expected: points whose distance to the box is below 0.045 (inside: distance 0).
  std::size_t near = 0;
  const std::vector<Vec3r> lattice = blockPositions(block, scene.fluid.spacing);
  for (const Vec3r& p : lattice) {
    const Eigen::Vector3d lo(0.28, 0.28, 0.08), hi(0.62, 0.62, 0.42);
    const Eigen::Vector3d q = p.cast<double>();
    const double d = (q - q.cwiseMax(lo).cwiseMin(hi)).norm();
    if (d < 0.045) ++near;
  }
  ASSERT_GT(near, 27u);  // the 27 inside and the layers 0.03 m off the faces
  Simulation simulation(simulationSettings(scene));
  setUpSimulation(scene, simulation, nullptr);
  EXPECT_EQ(simulation.particles().size(), lattice.size() - near);
}

} // namespace cascade::scene

TEST(SceneSetup, MemoryEstimateCountsTheLatticesAndTheWalls) {
  // A 1 x 0.5 x 0.2 m block at 1 cm (100 x 50 x 20 particles) in a 1 x 0.5 x 0.4 m tank
  // (floor and walls 1.1 m^2, samples half a spacing apart: 4 / spacing^2 per m^2).
  Scene scene;
  scene.fluid.spacing = 0.01;
  scene.fluid.blocks.push_back(FluidBlock{Box{{0, 0, 0}, {1, 0.5, 0.2}}, {0, 0, 0}});
  scene.boundaries.tank = Box{{0, 0, 0}, {1, 0.5, 0.4}};
  const MemoryEstimate estimate = estimateBakeMemory(scene);
  EXPECT_DOUBLE_EQ(estimate.fluidParticles, 100.0 * 50 * 20);
  EXPECT_NEAR(estimate.boundarySamples, (0.5 + 2 * 0.4 + 2 * 0.2) * 4e4, 1e-6);
  EXPECT_DOUBLE_EQ(estimate.bytes, kBytesPerFluidParticle * 1e5 + kBytesPerBoundarySample * estimate.boundarySamples);
  EXPECT_GT(availableMemory(), 1e8);  // this machine has more than 100 MB
}
