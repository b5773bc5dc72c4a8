/// @file FluidSources.h
/// @brief Where fluid particles come from and where they leave: initial
///        blocks on the fluid lattice, nozzle emitters (disk or rectangle)
///        and kill regions (scene "fluid" and "boundaries.kill").
///
/// Blocks: particles on a cubic lattice of the fluid spacing, centred in the
/// box (half a spacing from its faces when the extent is a multiple of it).
/// Emitters: a layer of particles on a square lattice over the nozzle area is
/// released every spacing / speed seconds (or at the scene's rate); a layer
/// due at time t_k and emitted at the end of a step at time t is placed
/// speed * (t - t_k) downstream, so the jet stays on the lattice whatever
/// the time step. The emitter state is two integers, saved in checkpoints,
/// so a resumed bake emits exactly what an uninterrupted one does.
#pragma once

#include "libsph/Particles.h"
#include "libsph/scene/Scene.h"

#include <cstdint>
#include <functional>
#include <vector>

namespace cascade::scene {

/// Lattice positions filling a fluid block.
std::vector<Vec3r> blockPositions(const FluidBlock& block, double spacing);

/// The particle lattice of one nozzle layer, in world coordinates at the nozzle centre.
std::vector<Vec3r> emitterLayer(const Emitter& emitter, double spacing);

/// Layers per second of an emitter (from its rate, or speed / spacing).
double emitterLayerRate(const Emitter& emitter, double spacing);

/// What an emitter has done so far (checkpointed).
struct EmitterState {
  std::int64_t layers = 0;    ///< layers released
  std::int64_t emitted = 0;   ///< particles released
};

/// Emits every layer due by time `time` through add(position, velocity).
/// Returns the number of particles added.
std::size_t emitUntil(const Emitter& emitter, const std::vector<Vec3r>& layer, double spacing,
                      double time, EmitterState& state,
                      const std::function<void(const Vec3r&, const Vec3r&)>& add);

/// Inflow buffer of a nozzle (the emitter's "pipe"): while the emitter runs
/// (start <= time <= end), every particle over the nozzle area (the layer
/// lattice plus half a spacing) from one spacing behind the nozzle plane to
/// `bufferLayers` spacings in front of it moves at the nozzle velocity.
/// Without it the jet's own pressure (water piling up downstream, where the
/// stream meets a slope or pool) pushes the newest layers back through the
/// nozzle plane, where the next layer is placed on top of them: pressure of
/// ~100 rho_0 g h, a blast that throws particles backwards at tens of m/s
/// (production bunny, t = 0.19 s). A held buffer is the usual SPH inflow
/// condition (prescribed-velocity inflow particles); it keeps the emitted
/// layers on their lattice until they are a kernel support away.
/// Nothing is held once an emitter's maximum count is out.
/// Returns the number of particles held. Stateless: a resumed bake holds the
/// same particles as an uninterrupted one.
std::size_t holdInflow(const Emitter& emitter, double spacing, double time, const EmitterState& state,
                       Particles& particles, double bufferLayers = 4.0);

/// Flags (1) particles inside any kill box or outside the domain box.
/// Returns how many were flagged.
std::size_t flagLeavingParticles(const Boundaries& boundaries, const Particles& particles,
                                 std::vector<char>& flags);

} // namespace cascade::scene
