// `cascade bench step`: the whole WCSPH time step (SEED (4)-(15)) with its
// boundary work on a dam break (a column of width m, depth m/2 and height 2m
// against the back wall of an open tank 4m long: Martin & Moyce's n^2 = 2
// geometry in 3D), at about 10 k, 100 k and 1 M fluid particles. The type I
// particles sample the tank walls; type II mirrors are rebuilt every step.
//
// After a few warm-up steps (start-up, first Morton reorder) the step is timed
// over a fixed number of steps; the split comes from Simulation::timings():
// neighbour search (with the periodic Morton reorder), density (SEED (4), (10)),
// forces (SEED (5), (6), artificial viscosity, gravity), boundary (virtual
// particle lists, mirror density and forces, SEED (11) repulsion), integration
// (SEED (12)-(14), domain and stability checks). boundary_samples is the type I
// sample count (n_boundary, the same count under its first name), and
// samples_per_area their count per area / gap^2 (1 on the walls' lattices; meshes:
// docs/boundary-sampling.md). particle_steps_per_s is
// n_fluid x steps / wall time, t_s the simulated time the timed steps start at.
// stderr also shows the CPU time of all threads (the machine is shared; other jobs
// stretch wall-clock times).
//
// `--from OUT` times a shot instead: the bake in OUT continued from its checkpoint (the
// last frame `cascade bake` completed there; bake some frames first), so a production
// scene is measured where its water meets its solids rather than at its start. OUT is
// only read. The steps are the solver's own (Simulation::step): emitters release no
// layer and no frame or probe time shortens a step while they run.
#include "Benchmarks.h"

#include "libsph/Errors.h"
#include "libsph/boundary/BoxBoundary.h"
#include "libsph/io/OutputLayout.h"
#include "libsph/scene/BakeCheckpoint.h"
#include "libsph/scene/Manifest.h"
#include "libsph/scene/SceneJson.h"
#include "libsph/scene/SceneSetup.h"
#include "libsph/solver/Simulation.h"

#include <chrono>
#include <cmath>
#include <ctime>
#include <iostream>

namespace cascade::cli {

namespace {

double processCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

struct Case {
  std::size_t target;
  int warmup, steps;
};

} // namespace

SimulationSettings benchDamBreakSettings() {
  SimulationSettings settings;
  settings.fluid.spacing = Real(0.01);
  return settings;
}

void addBenchDamBreak(Simulation& sim, std::size_t target) {
  // Column m x m/2 x 2m spacings: m^3 particles.
  const Real spacing = sim.settings().fluid.spacing;
  const int m = int(std::lround(std::cbrt(double(target))));
  const Real width = spacing * Real(m), depth = spacing * Real(m / 2), height = 2 * width;
  sim.addBoundary(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(4 * width, depth, Real(1.25) * height)));
  sim.addFluidBox(Vec3r(0, 0, 0), Vec3r(width, depth, height));
}

namespace {

const std::vector<std::string> kStepColumns = {"case", "solver", "n_fluid", "n_boundary", "boundary_samples",
                                               "samples_per_area", "ms_per_step", "neighbors_ms", "density_ms",
                                               "forces_ms", "boundary_ms", "integrate_ms", "particle_steps_per_s", "t_s"};

/// Times `steps` steps of sim after `warmup` untimed ones, as a row of kStepColumns.
std::vector<BenchTable::Value> timeSteps(Simulation& sim, const std::string& name, int warmup, int steps) {
  const std::size_t fluid = sim.particles().size();
  for (int k = 0; k < warmup; ++k) sim.step();
  sim.resetTimings();
  const double startTime = sim.time();
  const double cpuStart = processCpuMs();
  const auto start = std::chrono::steady_clock::now();
  for (int k = 0; k < steps; ++k) sim.step();
  const double wallMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  const double cpuMs = processCpuMs() - cpuStart;
  const StepTimings& t = sim.timings();
  const double count = double(steps);
  double area = 0;
  for (std::size_t b = 0; b < sim.boundaryCount(); ++b) area += surfaceArea(sim.boundary(b).surfaceMesh());
  const double gap = double(sim.boundaryParticles().sampleGap());
  const std::size_t samples = sim.boundaryParticleCount();
  std::cerr << "bench step: " << name << ", " << fluid << " fluid: " << wallMs / count << " ms/step wall, "
            << cpuMs / count << " ms/step CPU (all threads), t = " << sim.time() << " s" << std::endl;
  return {name, sim.timeStep().name(), static_cast<long long>(fluid), static_cast<long long>(samples),
          static_cast<long long>(samples), area > 0 ? double(samples) * gap * gap / area : 0.0, wallMs / count,
          t.neighbors / count, t.density / count, t.forces / count, t.boundary / count, t.integrate / count,
          double(fluid) * count / (wallMs / 1000.0), startTime};
}

} // namespace

BenchTable benchStep() {
  BenchTable table("step", kStepColumns);
  const Case cases[] = {{10000, 10, 200}, {100000, 5, 40}, {1000000, 3, 8}};
  for (const Case& c : cases) {
    Simulation sim(benchDamBreakSettings());
    addBenchDamBreak(sim, c.target);
    std::cerr << "bench step: " << sim.particles().size() << " fluid particles, warming up..." << std::endl;
    table.addRow(timeSteps(sim, "dam break", c.warmup, c.steps));
  }
  return table;
}

BenchTable benchStepFrom(const std::filesystem::path& out, int steps) {
  const OutputLayout layout(out);
  const std::filesystem::path checkpoint = scene::checkpointPath(out);
  if (!std::filesystem::exists(layout.scene()))
    throw InputError("bench step --from: " + out.string() + " holds no bake (no scene.json)");
  const std::optional<scene::BakeCheckpoint> header = scene::readCheckpointHeader(checkpoint);
  if (!header)
    throw InputError("bench step --from: " + out.string() +
                     " has no bake checkpoint (bake some frames there first: cascade bake SCENE -o OUT --frames 1-N)");
  const scene::Scene scene = scene::loadScene(layout.scene().string(), {});
  if (scene::sceneInputHash(scene) != header->inputHash)
    throw InputError("bench step --from: the checkpoint in " + out.string() +
                     " is of another version of its scene (bake again)");
  Simulation sim(scene::simulationSettings(scene));
  scene::setUpSimulation(scene, sim, nullptr);
  const scene::BakeCheckpoint state = scene::readCheckpoint(checkpoint, sim);
  std::cerr << "bench step: " << scene.name << " from frame " << state.frame << " (t = " << sim.time() << " s), "
            << sim.particles().size() << " fluid particles" << std::endl;
  BenchTable table("step", kStepColumns);
  table.addRow(timeSteps(sim, scene.name + " frame " + std::to_string(state.frame), 2, steps));
  return table;
}

} // namespace cascade::cli
