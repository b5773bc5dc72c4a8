// `cascade bench bodies`: what a floating body costs a step. The shipped
// bunny_drop scene (production size; CASCADE_BENCH_SIZE=seed for a quick run), with the
// bunny already floating (its centre of mass at the water level, so both runs have it
// in the water), baked for a fixed number of steps twice: as a rigid body (its samples
// placed, its mirrors conjugated, its force and torque integrated, its contacts), and
// held static at the same place. ratio = ms_per_step(dynamic) / ms_per_step(static).
// Both solvers; the phase split comes from Simulation::timings().
#include "Benchmarks.h"

#include "libsph/scene/SceneJson.h"
#include "libsph/scene/SceneSetup.h"
#include "libsph/solver/Simulation.h"

#include <chrono>
#include <cstdlib>
#include <iostream>

namespace cascade::cli {

BenchTable benchBodies() {
  BenchTable table("bodies", {"solver", "body", "n_fluid", "n_boundary", "ms_per_step", "neighbors_ms", "forces_ms",
                              "boundary_ms", "integrate_ms", "ratio"});
  const char* size = std::getenv("CASCADE_BENCH_SIZE");
  const std::string file = std::string(CASCADE_SOURCE_DIR) + "/scenes/bunny_drop.json";
  for (const std::string solver : {"dfsph", "wcsph"}) {
    double staticMs = 0;
    for (const bool dynamic : {false, true}) {
      scene::Scene scene = scene::loadScene(file, {std::string("size=") + (size ? size : "production"),
                                                   "solver.type=" + solver});
      scene::Obstacle& bunny = scene.boundaries.obstacles.at(0);
      bunny.translate[2] -= 0.264;  // centre of mass (0.514 m as shipped) to the water level, 0.25 m
      if (!dynamic) bunny.dynamic.reset();
      Simulation sim(scene::simulationSettings(scene));
      scene::setUpSimulation(scene, sim, nullptr);
      const int warmup = 5, steps = size && std::string(size) == "seed" ? 200 : 40;
      std::cerr << "bench bodies: " << solver << ", bunny " << (dynamic ? "dynamic" : "static") << ", "
                << sim.particles().size() << " fluid particles, warming up..." << std::endl;
      for (int k = 0; k < warmup; ++k) sim.step();
      sim.resetTimings();
      const auto start = std::chrono::steady_clock::now();
      for (int k = 0; k < steps; ++k) sim.step();
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count() / steps;
      if (!dynamic) staticMs = ms;
      const StepTimings& t = sim.timings();
      table.addRow({solver, std::string(dynamic ? "dynamic" : "static"), static_cast<long long>(sim.particles().size()),
                    static_cast<long long>(sim.boundaryParticleCount()), ms, t.neighbors / steps, t.forces / steps,
                    t.boundary / steps, t.integrate / steps, dynamic ? ms / staticMs : 1.0});
    }
  }
  return table;
}

} // namespace cascade::cli
