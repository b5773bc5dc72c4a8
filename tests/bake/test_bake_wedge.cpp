// Production-scene contact failures, replayed on the scenes' own boundaries.
// Wedge: the bunny sits 7 mm below the floor; spray sliding along the floor
// into its base is squeezed between the floor's and the mesh's SEED (11)
// layers (production bunny, t = 0.596 s: particle 93 thrown out at 59 m/s,
// the tower at 334 m/s). The wedge contact limiter (TimeStepWCSPH.h) keeps
// it bounded.
#include "libsph/Errors.h"
#include "libsph/scene/SceneJson.h"
#include "libsph/scene/SceneSetup.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

namespace fs = std::filesystem;

namespace cascade::test {

TEST(BakeWedge, SpraySlidingIntoTheBunnysBaseStaysBounded) {
  scene::Scene scene = scene::loadScene(fs::path(CASCADE_SOURCE_DIR) / "scenes" / "bunny.json");
  scene.fluid.emitters.clear();  // only the boundaries: tank, slope, bunny
  Simulation simulation(scene::simulationSettings(scene));
  // Emitter-derived expected speed of the production scene (2.5 m/s in the file).
  scene::setUpSimulation(scene, simulation, nullptr);
  // Particle 93 of the production bake 0.01 s before it blew up, and a neighbour behind it.
  simulation.addParticle(Vec3r(0.1729f, 0.0169f, 0.0024f), Vec3r(3.176f, -0.010f, -0.002f));
  simulation.addParticle(Vec3r(0.1679f, 0.0189f, 0.0025f), Vec3r(3.176f, -0.010f, -0.002f));
  Real maxSpeed = 0;
  ASSERT_NO_THROW({
    while (simulation.time() < 0.03) {
      simulation.step();
      for (const Vec3r& v : simulation.particles().velocity) maxSpeed = std::max(maxSpeed, v.norm());
    }
  });
  std::printf("[wedge] max speed %.3f m/s over %llu steps\n", double(maxSpeed),
              static_cast<unsigned long long>(simulation.stepCount()));
  // The walls add no energy: the slide's 3.2 m/s (plus gravity over millimetres).
  EXPECT_LE(maxSpeed, Real(3.3));
  for (const Vec3r& x : simulation.particles().position)
    for (std::size_t b = 0; b < simulation.boundaryCount(); ++b)
      EXPECT_FALSE(simulation.boundary(b).isInside(x)) << simulation.boundary(b).kind() << " " << x.transpose();
}

} // namespace cascade::test
