/// @file SlabDecomposition.h
/// @brief The fluid's domain cut into slabs along one axis, one slab per rank:
///        who owns a point, which ranks need it as a ghost, and cuts that give
///        every rank the same number of particles (from the particles
///        themselves, or from a histogram summed over ranks when rebalancing).
///
/// Rank r owns the half-open slab [cut_{r-1}, cut_r) along the axis, with
/// cut_{-1} = -inf and cut_{R-1} = +inf, so every point has exactly one owner.
/// Slabs (a one-dimensional decomposition, as in DualSPHysics-MPI's first
/// version, Valdez-Balderas et al. 2013) keep each rank's halo to two faces;
/// the axis is the scene's longest horizontal one, where a splash spreads.
#pragma once

#include "libsph/Types.h"

#include <cstdint>
#include <vector>

namespace cascade::distributed {

struct SlabDecomposition {
  int axis = 0;             ///< 0, 1 or 2: x, y or z
  std::vector<Real> cuts;   ///< rankCount() - 1 ascending coordinates

  int rankCount() const { return int(cuts.size()) + 1; }
  /// The rank whose slab holds `coordinate` (along the axis).
  int ownerOf(Real coordinate) const;
  /// The lowest and highest rank whose slab comes within `halo` of `coordinate`
  /// (the owner included).
  void ranksWithin(Real coordinate, Real halo, int& first, int& last) const;
};

/// Cuts that split `coordinates` into rankCount runs of equal count (to one
/// particle): each cut halfway between the last coordinate of a run and the next.
/// Equal coordinates (a lattice plane) stay together, in the upper slab.
std::vector<Real> balancedCuts(std::vector<Real> coordinates, int rankCount);

/// The same from a histogram of `bins` equal bins over [lo, hi]: each cut at the
/// bin edge where the running count reaches r / rankCount of the total.
std::vector<Real> balancedCutsFromHistogram(const std::vector<std::uint64_t>& bins, Real lo, Real hi,
                                            int rankCount);

/// The bin of `coordinate` in `binCount` equal bins over [lo, hi] (clamped).
std::size_t histogramBin(Real coordinate, Real lo, Real hi, std::size_t binCount);

/// Whether a share is more than `tolerance` (0.1: 10 %) above or below the mean.
bool unbalanced(const std::vector<std::uint64_t>& counts, double tolerance);

/// The longer of the two axes perpendicular to gravity's largest component, over [lo, hi].
int slabAxis(const Vec3r& lo, const Vec3r& hi, const Vec3r& gravity);

} // namespace cascade::distributed
