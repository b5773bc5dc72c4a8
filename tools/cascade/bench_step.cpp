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
// n_fluid x steps / wall time. stderr also shows the CPU time of all threads
// (the machine is shared; other jobs stretch wall-clock times).
#include "Benchmarks.h"

#include "libsph/boundary/BoxBoundary.h"
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

BenchTable benchStep() {
  BenchTable table("step", {"solver", "n_fluid", "n_boundary", "boundary_samples", "samples_per_area", "ms_per_step",
                            "neighbors_ms", "density_ms", "forces_ms", "boundary_ms", "integrate_ms",
                            "particle_steps_per_s"});
  const Case cases[] = {{10000, 10, 200}, {100000, 5, 40}, {1000000, 3, 8}};
  for (const Case& c : cases) {
    Simulation sim(benchDamBreakSettings());
    addBenchDamBreak(sim, c.target);
    const std::size_t fluid = sim.particles().size();
    std::cerr << "bench step: " << fluid << " fluid particles, warming up..." << std::endl;
    for (int k = 0; k < c.warmup; ++k) sim.step();
    sim.resetTimings();
    const double cpuStart = processCpuMs();
    const auto start = std::chrono::steady_clock::now();
    for (int k = 0; k < c.steps; ++k) sim.step();
    const double wallMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    const double cpuMs = processCpuMs() - cpuStart;
    const StepTimings& t = sim.timings();
    const double steps = double(c.steps);
    double area = 0;
    for (std::size_t b = 0; b < sim.boundaryCount(); ++b) area += surfaceArea(sim.boundary(b).surfaceMesh());
    const double gap = double(sim.boundaryParticles().sampleGap());
    const std::size_t samples = sim.boundaryParticleCount();
    std::cerr << "bench step: " << fluid << " fluid: " << wallMs / steps << " ms/step wall, " << cpuMs / steps
              << " ms/step CPU (all threads), t = " << sim.time() << " s" << std::endl;
    table.addRow({std::string("wcsph"), static_cast<long long>(fluid), static_cast<long long>(samples),
                  static_cast<long long>(samples), area > 0 ? double(samples) * gap * gap / area : 0.0, wallMs / steps, t.neighbors / steps,
                  t.density / steps, t.forces / steps, t.boundary / steps, t.integrate / steps,
                  double(fluid) * steps / (wallMs / 1000.0)});
  }
  return table;
}

} // namespace cascade::cli
