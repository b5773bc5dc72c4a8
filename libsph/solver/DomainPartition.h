/// @file DomainPartition.h
/// @brief What a Simulation needs from a spatial decomposition of its fluid
///        over cooperating processes (MPI ranks; distributed/MpiSlabPartition.h
///        implements it): ownership of a region, migration of particles
///        between regions, ghost (halo) copies of the neighbours' particles,
///        and the reductions that make every rank take the same step.
///
/// Between steps a rank holds only the particles it owns. During a step it
/// also holds ghosts, appended after the owned particles: copies of other
/// ranks' particles within one support radius of its region, so that every
/// owned particle sees all of its neighbours (halo exchange, as in
/// DualSPHysics-MPI, Dominguez et al. 2013). Every call below is collective
/// unless it says otherwise: all ranks make the same calls in the same order.
#pragma once

#include "libsph/Particles.h"
#include "libsph/Types.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace cascade {

class DomainPartition {
public:
  virtual ~DomainPartition() = default;

  virtual int rank() const = 0;
  virtual int rankCount() const = 0;

  /// Not collective: whether this rank owns a particle at `position`.
  virtual bool owns(const Vec3r& position) const = 0;

  /// Sets the regions from the whole starting fluid (the same on every rank, so every
  /// rank derives the same regions) within the scene's box [lo, hi] (fluid and bounded
  /// solids; what splits a scene that starts empty). Throws InputError when the fluid
  /// (or the box) cannot give every rank a region one support radius wide.
  virtual void start(const Particles& all, Real supportRadius, const Vec3r& lo, const Vec3r& hi,
                     const Vec3r& gravity) = 0;

  /// Sends each particle this rank holds but no longer owns to its owner and
  /// appends the ones it receives; first moves the regions if a rank's share has
  /// drifted more than the partition's tolerance from even.
  /// `state`: `width` Reals per particle that travel with it (a strategy's own
  /// per-particle state, TimeStep::packState); null for none.
  virtual void migrate(Particles& particles, std::vector<Real>* state = nullptr, std::size_t width = 0) = 0;

  /// Appends ghosts: copies of the other ranks' particles within `halo` of this
  /// rank's region (positions, velocities, densities, pressures, ids). Remembers
  /// where each ghost came from for refreshGhosts().
  virtual void addGhosts(Particles& particles, Real halo) = 0;
  /// Copies the owners' current values into the ghosts of the last addGhosts()
  /// (owned particles [0, ownedCount), ghosts after them; one value per particle).
  virtual void refreshGhosts(Real* values, std::size_t ownedCount) = 0;
  virtual void refreshGhosts(Vec3r* values, std::size_t ownedCount) = 0;

  /// The largest of each of `count` values over all ranks, in place (exact, so every
  /// rank gets the same step).
  virtual void maxOverRanks(double* values, std::size_t count) = 0;
  double maxOverRanks(double value) {
    maxOverRanks(&value, 1);
    return value;
  }
  /// Sums `count` values over all ranks, in rank order (the same result on every rank).
  virtual void sumOverRanks(double* values, std::size_t count) = 0;
  /// The first non-empty message over ranks in rank order, on every rank ("" if none).
  virtual std::string firstMessage(const std::string& local) = 0;

  /// Not collective: what this rank's exchanges have done so far (logs, benchmarks).
  struct Statistics {
    double communicationSeconds = 0;  ///< wall time in exchanges, reductions and gathers
    std::size_t lastGhosts = 0;       ///< ghosts received for the last step
    std::uint64_t migrated = 0;       ///< particles sent to another rank
    std::uint64_t rebalances = 0;
  };
  virtual Statistics statistics() const = 0;

  /// All ranks' particles, sorted by id, on rank 0 (empty elsewhere); with `state`
  /// (`width` Reals per particle), theirs too, in the same order, into gatheredState.
  virtual Particles gatherToFirst(const Particles& owned, const std::vector<Real>* state = nullptr,
                                  std::size_t width = 0, std::vector<Real>* gatheredState = nullptr) = 0;
};

} // namespace cascade
