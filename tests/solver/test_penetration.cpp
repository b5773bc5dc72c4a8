// No penetration (validation): a 5 m/s jet against the bunny
// obstacle (the bunny scene's mesh: the SEED's 3,851-triangle scan with its
// holes filled, simplified to 900 triangles, SEED section 2.2):
// no fluid particle inside the mesh (generalised winding number) at any
// output frame, while the jet does hit it (the force probe sees the impact).
#include "libsph/boundary/MeshBoundary.h"
#include "libsph/probes/Probes.h"
#include "libsph/solver/Simulation.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>

namespace cascade::test {

TEST(NoPenetration, JetAgainstTheBunnyNeverEntersTheMesh) {
  const std::string path = std::string(CASCADE_SOURCE_DIR) + "/scenes/assets/bunny_res3.ply";
  ASSERT_TRUE(std::filesystem::exists(path)) << path << " missing";
  const Real spacing = 0.01f, speed = 5.0f, nozzleRadius = 0.03f;
  SimulationSettings settings;
  settings.fluid.spacing = spacing;
  settings.solver.expectedSpeed = speed;
  settings.domain.enabled = true;
  settings.domain.min = Vec3r(-0.4f, -0.4f, -0.4f);
  settings.domain.max = Vec3r(0.4f, 0.4f, 0.4f);
  Simulation sim(settings);
  MeshObstacleOptions options;
  options.targetTriangles = 900;
  // The scan in its own metres (0.156 m wide), scaled to a 0.2 m bunny centred at the origin.
  options.transform.scale = 1.28455f;
  options.transform.translation = Vec3r(0.021631f, -0.001974f, -0.141498f);
  options.transform.rotation = Transform::rotationFromEulerDegrees(Vec3r(90, 0, 0));  // y up -> z up
  std::ostringstream log;
  auto bunny = MeshBoundary::load(path, options, &log);
  const MeshBoundary& mesh = *bunny;
  bunny->setName("bunny");
  sim.addBoundary(std::move(bunny));
  std::cout << log.str();

  // The nozzle: a disk of the fluid lattice at x = -0.2 aimed along +x at the body.
  std::vector<Vec3r> disk;
  for (int j = -3; j <= 3; ++j)
    for (int k = -3; k <= 3; ++k) {
      const Vec3r p(0, spacing * j, spacing * k);
      if (p.norm() <= nozzleRadius) disk.push_back(p + Vec3r(-0.2f, 0, -0.02f));
    }
  const double layerInterval = spacing / speed, endTime = 0.12, frameInterval = 0.005;
  double nextLayer = 0, nextFrame = frameInterval;
  std::size_t inside = 0, frames = 0, nearSurface = 0;
  double peakForce = 0;
  while (sim.time() < endTime - 1e-9) {
    if (sim.time() >= nextLayer - 1e-9 && sim.time() < 0.08) {
      for (const Vec3r& p : disk) sim.addParticle(p, Vec3r(speed, 0, 0));
      nextLayer += layerInterval;
    }
    sim.advanceTo(sim.time() < 0.08 ? std::min(nextLayer, nextFrame) : nextFrame);
    peakForce = std::max(peakForce, obstacleForce(sim, "bunny").x());
    if (sim.time() >= nextFrame - 1e-9) {
      ++frames;
      nextFrame += frameInterval;
      for (const Vec3r& x : sim.particles().position) {
        if (mesh.isInside(x)) ++inside;
        Vec3r point, normal;
        if (mesh.closestPoint(x, 2 * spacing, point, normal)) ++nearSurface;
      }
    }
  }
  std::cout << "jet: " << frames << " frames, " << sim.particles().size() << " particles, "
            << sim.removedCount() << " left the domain, particle-frames within 2 spacings of the bunny "
            << nearSurface << ", inside " << inside << ", peak force on the bunny " << peakForce << " N\n";
  EXPECT_EQ(inside, 0u);
  EXPECT_GT(nearSurface, 1000u);  // the jet did reach the bunny
  EXPECT_GT(peakForce, 1.0);
}

} // namespace cascade::test
