/// @file FluidInterval.h
/// @brief The fluid between two cached frames: particles matched by id, their
///        positions by cubic Hermite interpolation of the two frames' positions
///        and velocities (exact for a particle in free fall or at constant
///        velocity), their velocities the interpolant's derivative.
///
/// The particles are those of the first frame, in its order. One that is gone
/// from the second frame (removed by a domain or kill box) moves on at its
/// velocity; one new in the second (an emitter's) joins at the next interval.
/// Caches without ids match by index when both frames hold the same count.
#pragma once

#include "libsph/io/ParticleCache.h"
#include "whitewater/DiffuseParticles.h"

#include <vector>

namespace cascade::whitewater {

class FluidInterval {
public:
  /// `first` at time t0, `second` at t1 > t0. Throws InputError (naming `label`)
  /// if a frame has no velocities, or they cannot be matched.
  FluidInterval(const ParticleFrame& first, const ParticleFrame& second, double t0, double t1,
                const std::string& label) {
    assign(first, second, t0, t1, label);
  }
  FluidInterval() = default;
  /// The same for another pair of frames, reusing the memory.
  void assign(const ParticleFrame& first, const ParticleFrame& second, double t0, double t1,
              const std::string& label);

  std::size_t size() const { return mX0.size(); }
  double t0() const { return mT0; }
  double t1() const { return mT1; }

  /// Positions and velocities of the fluid at time t in [t0, t1] (resized to size()).
  void at(double t, std::vector<Vec3r>& positions, std::vector<Vec3r>& velocities) const;

  /// The largest speed of a particle at either end, m/s.
  double maxSpeed() const { return mMaxSpeed; }

  /// Ids of the particles (those of the first frame, or indices without ids).
  const std::vector<std::uint32_t>& ids() const { return mIds; }
  /// Where each particle is in the second frame's order (-1: gone from it).
  const std::vector<std::int64_t>& secondIndex() const { return mSecondIndex; }
  /// The particles' positions in the first frame, and in the second (where
  /// secondIndex() >= 0): what at(t0()) and at(t1()) give there.
  const std::vector<Vec3r>& startPositions() const { return mX0; }
  const std::vector<Vec3r>& endPositions() const { return mX1; }

private:
  double mT0 = 0, mT1 = 1, mMaxSpeed = 0;
  std::vector<Vec3r> mX0, mV0, mX1, mV1, mScratchX, mScratchV;
  std::vector<std::uint8_t> mMatched;
  std::vector<std::uint32_t> mIds;
  std::vector<std::int64_t> mWhere, mSecondIndex;
};

/// Positions and velocities of a frame as float arrays (throws InputError naming
/// `label` without velocities).
void fluidArrays(const ParticleFrame& frame, std::vector<Vec3r>& positions, std::vector<Vec3r>& velocities,
                 const std::string& label);

} // namespace cascade::whitewater
