#pragma once
// Fluids for the whitewater tests: lattices of particles at rest or moving,
// as two cache frames of a FluidInterval.
#include "libsph/io/ParticleCache.h"

#include <cstdint>

namespace cascade::test {

/// A block of fluid on a lattice of `spacing` over [min, max), every particle at `velocity`.
inline ParticleFrame latticeFluid(const Vec3r& min, const Vec3r& max, Real spacing, const Vec3r& velocity) {
  ParticleFrame frame;
  frame.spacing = spacing;
  std::uint32_t id = 0;
  for (Real z = min.z() + spacing / 2; z < max.z(); z += spacing)
    for (Real y = min.y() + spacing / 2; y < max.y(); y += spacing)
      for (Real x = min.x() + spacing / 2; x < max.x(); x += spacing) {
        frame.position.emplace_back(x, y, z);
        frame.velocity.push_back(velocity);
        frame.id.push_back(id++);
      }
  return frame;
}

/// The same frame moved on by its velocities over dt, at time + dt.
inline ParticleFrame movedOn(const ParticleFrame& frame, double dt) {
  ParticleFrame next = frame;
  for (std::size_t i = 0; i < next.size(); ++i) next.position[i] += Real(dt) * next.velocity[i];
  next.time = frame.time + dt;
  return next;
}

} // namespace cascade::test
