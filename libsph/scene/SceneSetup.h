/// @file SceneSetup.h
/// @brief Maps a scene (Scene.h) onto the solver: SimulationSettings, the
///        boundaries (tank, planes, slopes, mesh obstacles) and the initial
///        fluid blocks. Solver, boundary and probe logic stay in libsph/solver,
///        libsph/boundary and libsph/probes; this file only translates.
///
/// Only what the scene needs is created: no obstacle -> no mesh boundary, zero
/// viscosity -> the solver skips its viscosity pass, no probe -> no probe work.
#pragma once

#include "libsph/scene/Scene.h"
#include "libsph/solver/Simulation.h"
#include "libsph/solver/SolverSettings.h"

#include <iosfwd>

namespace cascade::scene {

/// The solver settings of a scene. When the scene has emitters and no
/// expected speed, it is derived here from the emitter speeds and the free
/// fall from the highest source (the solver only sees particles present at
/// the start).
SimulationSettings simulationSettings(const Scene& scene);

/// Adds the scene's boundaries (in scene order: tank, planes, slopes,
/// obstacles) and initial fluid blocks to `simulation`, without the block
/// particles that lie inside a solid or within half a spacing of an earlier
/// block (blocks fill their union once; both logged). Mesh loading and
/// simplification are logged to `log` if not null, and so is a warning when a
/// dfsph scene starts with water deeper than DFSPH is measured to hold still
/// (kDfsphStillWaterLayers) or asks for a CFL factor above the one it holds (kDfsphMaxCfl).
void setUpSimulation(const Scene& scene, Simulation& simulation, std::ostream* log);

/// What a bake of the scene is estimated to need before anything is allocated: the
/// fluid particles (the blocks' lattices and what the emitters put out by the end
/// time or their limit) at kBytesPerFluidParticle each (state and neighbour lists),
/// and the type I boundary samples (the tank's, slopes' and planes' area at half a
/// spacing apart; meshes' are small beside them) at kBytesPerBoundarySample each.
/// Measured on the production tower: 205,905 particles and 3.45 M samples peak at 316 MB.
struct MemoryEstimate {
  double fluidParticles = 0, boundarySamples = 0, bytes = 0;
};
constexpr double kBytesPerFluidParticle = 1024, kBytesPerBoundarySample = 32;
MemoryEstimate estimateBakeMemory(const Scene& scene);
/// Memory this process may still take, bytes: MemAvailable (/proc/meminfo), else the
/// physical memory; 0 if unknown.
double availableMemory();

/// The most particle layers any fluid block stacks along gravity (its extent along
/// gravity over the spacing); 0 without blocks or gravity.
int deepestFluidLayers(const Scene& scene);

} // namespace cascade::scene
