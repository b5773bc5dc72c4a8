// Stability stress cases shared by the full suite (label stress) and its quick
// subset (default run). Each case runs a small scene and either stays stable
// -- finite state, no particle through a wall or inside the obstacle, kinetic
// energy bounded by the energy the scene can release -- or stops with
// cascade::InstabilityError whose message names particle, position and time.
#pragma once

#include "libsph/Errors.h"
#include "libsph/boundary/BoxBoundary.h"
#include "libsph/boundary/MeshBoundary.h"
#include "libsph/solver/Simulation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <iostream>
#include <regex>
#include <string>

namespace cascade::stress {

struct Outcome {
  bool unstable = false;
  std::string message;        ///< InstabilityError text
  double maxKinetic = 0;      ///< J, largest over the samples
  double energyBound = 0;     ///< J
  std::size_t leaked = 0;     ///< particles found through a wall or inside an obstacle
  std::uint64_t keptOut = 0;  ///< times Simulation::keepOutOfSolids put a particle back out
  std::uint64_t steps = 0;
  double time = 0;
};

inline double kineticEnergy(const Particles& p) {
  double e = 0;
  for (const Vec3r& v : p.velocity) e += 0.5 * double(p.mass) * double(v.squaredNorm());
  return e;
}

inline double potentialEnergy(const Particles& p, const Vec3r& gravity) {
  double e = 0;
  for (const Vec3r& x : p.position) e -= double(p.mass) * double(gravity.dot(x));
  return e;
}

/// Runs `sim` for `steps` steps (or until endTime if steps == 0), sampling every
/// `sampleEvery` steps. `solids` are checked for particles inside them (tank:
/// through a wall). extraEnergy: energy the initial state stores beyond kinetic
/// and potential (J; e.g. overlapping particles), added to the bound.
inline Outcome run(Simulation& sim, std::uint64_t steps, double endTime, const std::vector<const Boundary*>& solids,
                   double extraEnergy = 0, std::uint64_t sampleEvery = 50) {
  Outcome out;
  const Vec3r g = sim.settings().solver.gravity;
  sim.nextTimeStep();  // starts the simulation (derived constants)
  const double initial = kineticEnergy(sim.particles()) + potentialEnergy(sim.particles(), g);
  // Lowest reachable potential: every particle on the lowest solid point.
  double lowest = 1e30;
  for (const Boundary* b : solids) {
    Vec3r lo, hi;
    b->bounds(lo, hi);
    lowest = std::min(lowest, double(lo.z()));
  }
  const double minPotential = double(sim.particles().mass) * double(sim.particles().size()) * (-g.z()) * lowest;
  out.energyBound = 1.05 * (initial - minPotential + extraEnergy) + 1e-9;
  auto check = [&] {
    const Particles& p = sim.particles();
    out.maxKinetic = std::max(out.maxKinetic, kineticEnergy(p));
    for (const Vec3r& x : p.position) {
      if (!x.allFinite()) { ++out.leaked; continue; }
      for (const Boundary* b : solids)
        if (b->isInside(x)) { ++out.leaked; break; }
    }
  };
  try {
    std::uint64_t k = 0;
    while (steps ? k < steps : sim.time() < endTime) {
      sim.step();
      ++k;
      if (k % sampleEvery == 0) check();
    }
    check();
  } catch (const InstabilityError& e) {
    out.unstable = true;
    out.message = e.what();
  }
  out.steps = sim.stepCount();
  out.time = sim.time();
  out.keptOut = sim.keptOutCount();
  return out;
}

/// The contract of every case: stable within bounds, or a proper instability stop.
inline void expectStableOrStopped(const Outcome& o, const std::string& name) {
  std::cout << "[stress] " << name << ": "
            << (o.unstable ? "stopped (InstabilityError): " + o.message : std::string("stable"))
            << " | steps " << o.steps << ", t " << o.time << " s, max kinetic " << o.maxKinetic << " J (bound "
            << o.energyBound << " J), leaked " << o.leaked << ", put back out " << o.keptOut << "\n";
  // No particle may pass through a wall, also not in the frames before an instability stop
  // (those frames stay on disk and must be valid).
  EXPECT_EQ(o.leaked, 0u) << name;
  if (o.unstable) {
    static const std::regex form(R"(particle \d+ at \(.*\), t = [0-9.e+-]+ s)");
    EXPECT_TRUE(std::regex_search(o.message, form)) << o.message;
  } else {
    EXPECT_LE(o.maxKinetic, o.energyBound) << name;
  }
}

inline SimulationSettings baseSettings(const std::string& solver, Real spacing) {
  SimulationSettings s;
  s.fluid.spacing = spacing;
  s.solver.type = solver;
  s.solver.cflFactor = Real(solver == "dfsph" ? 0.5 : 0.4);
  return s;
}

/// Still water: a 0.1 m cube of water in a 0.1 m tank, spacing 1 cm.
inline Outcome stillWater(const std::string& solver, std::uint64_t steps) {
  Simulation sim(baseSettings(solver, Real(0.01)));
  sim.addBoundary(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(0.1, 0.1, 0.2)));
  sim.addFluidBox(Vec3r(0, 0, 0), Vec3r(0.1, 0.1, 0.1));
  Outcome o = run(sim, steps, 0, {&sim.boundary(0)}, 0, 200);
  // Still water stays still: no more than 1 % of the column's potential energy as motion.
  const double columnEnergy = double(sim.particles().mass) * sim.particles().size() * 9.81 * 0.05;
  if (!o.unstable) {
    EXPECT_LT(o.maxKinetic, 0.01 * columnEnergy) << solver;
  }
  return o;
}

/// A small dam break (Martin & Moyce column, a = 5.7 cm, 8 particles across) with settings changed by `tweak`.
inline Outcome damBreak(const std::string& solver, double endTime, const std::function<void(SimulationSettings&)>& tweak,
                        bool overlapping = false) {
  const Real a = Real(0.05715), s = a / 8, w = 4 * s;
  SimulationSettings settings = baseSettings(solver, s);
  tweak(settings);
  Simulation sim(settings);
  sim.addBoundary(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(8 * a, w, 4 * a)));
  sim.addFluidBox(Vec3r(0, 0, 0), Vec3r(a, w, 2 * a));
  double extra = 0;
  if (overlapping) {
    // A second lattice shifted by half a spacing in x and z: twice the rest density
    // (particles half a spacing apart). The compression energy is of the order of
    // the weight lifted by the column doubling its height: M g 2a.
    sim.addFluidBox(Vec3r(s / 2, 0, s / 2), Vec3r(a, w, 2 * a));
    extra = double(sim.particles().mass) * sim.particles().size() * 9.81 * 2 * a * 4;
  }
  return run(sim, 0, endTime, {&sim.boundary(0)}, extra);
}

/// A thin sheet: one layer of particles, 0.2 m x 0.2 m, falling 0.1 m onto the tank floor.
inline Outcome thinSheet(const std::string& solver, double endTime) {
  const Real s = Real(0.01);
  Simulation sim(baseSettings(solver, s));
  sim.addBoundary(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(0.3, 0.3, 0.3)));
  sim.addFluidBox(Vec3r(0.05, 0.05, 0.1), Vec3r(0.25, 0.25, 0.1 + s));
  return run(sim, 0, endTime, {&sim.boundary(0)});
}

/// A jet at `speed` into the bunny (scenes/assets/bunny_full.obj, 0.2 m, 900 triangles) in a tank; no particle may
/// end inside it. cfl > 0 replaces the solver's CFL factor: at these speeds the velocity CFL, not the force limit,
/// sets DFSPH's step (the dam break's 1.5 m/s leaves it to the force limit at any CFL factor).
inline Outcome jetIntoBunny(const std::string& solver, double speed, double endTime, Real cfl = 0,
                            Real spacing = Real(0.01)) {
  const std::string path = std::string(CASCADE_SOURCE_DIR) + "/scenes/assets/bunny_full.obj";
  const Real s = spacing;
  SimulationSettings settings = baseSettings(solver, s);
  if (cfl > 0) settings.solver.cflFactor = cfl;
  settings.solver.expectedSpeed = Real(speed);
  settings.domain.enabled = true;
  settings.domain.min = Vec3r(-0.45, -0.3, -0.05);
  settings.domain.max = Vec3r(0.45, 0.3, 1.05);
  Simulation sim(settings);
  sim.addBoundary(BoxBoundary::tank(Vec3r(-0.4, -0.25, 0), Vec3r(0.4, 0.25, 1.0)));
  MeshObstacleOptions options;
  options.targetTriangles = 900;
  options.transform.scale = Real(0.1);  // the file spans [-1, 1]: a 0.2 m bunny, resting on the floor
  options.transform.rotation = Transform::rotationFromEulerDegrees(Vec3r(90, 0, 0));  // y up -> z up
  options.transform.translation = Vec3r(0.1, 0, 0.1);
  sim.addBoundary(MeshBoundary::load(path, options));
  // A 6 cm x 6 cm x 10 cm slug of water at the speed, aimed at the body.
  sim.addFluidBox(Vec3r(-0.35, -0.03, 0.06), Vec3r(-0.25, 0.03, 0.12), Vec3r(Real(speed), 0, 0));
  return run(sim, 0, endTime, {&sim.boundary(0), &sim.boundary(1)}, 0, 10);
}

} // namespace cascade::stress
