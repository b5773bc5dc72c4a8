/// @file ParticleCompare.h
/// @brief Two particle frames side by side, particle by particle: matched by id
///        (by file order when neither has ids), with the largest and the RMS
///        distance between a particle's two positions and velocities. What
///        `cascade inspect A --against B` prints: a farm's or an MPI bake's
///        caches against a local one, two solvers' or two versions' bakes.
#pragma once

#include "libsph/io/ParticleCache.h"

#include <cstddef>

namespace cascade {

struct ParticleDifference {
  bool byId = true;              ///< matched by id (false: by file order)
  std::size_t matched = 0;       ///< particles in both
  std::size_t onlyInA = 0, onlyInB = 0;
  double maxPosition = 0;        ///< m
  double rmsPosition = 0;        ///< m, over the matched particles
  ParticleId maxPositionId = 0;  ///< the particle (id, or index) of maxPosition
  double maxVelocity = 0;        ///< m/s; 0 unless both have velocities
  double rmsVelocity = 0;
};

/// Compares `a` with `b`. Frames without ids in both files are matched by
/// index; a frame with ids against one without throws InputError (they cannot
/// be matched).
ParticleDifference compareParticleFrames(const ParticleFrame& a, const ParticleFrame& b);

} // namespace cascade
