/// @file BoundarySampling.h
/// @brief Helpers to place type I boundary particles (SEED section 2.2) on
///        flat pieces: a rectangle sampled on a lattice with no gap above
///        maxGap (kept as a lattice for searching), and removal of coincident
///        samples where pieces share an edge.
#pragma once

#include "libsph/Types.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace cascade {

/// Intervals of a rectangle's lattice along a side of half length `half`: the
/// fewest with none longer than maxGap (at least one).
inline long rectangleIntervals(Real half, Real maxGap) {
  return std::max(1L, static_cast<long>(std::ceil(2 * half / maxGap - Real(1e-4))));
}

/// Type I samples on a flat rectangle as a lattice: the points
/// center + s axisU + t axisV, s = -halfU + 2 halfU i / intervalsU (t likewise
/// with j), for firstU <= i <= lastU and firstV <= j <= lastV. The full lattice
/// (0..intervals) includes the edges; a sub-range drops edges another piece
/// samples. Axes orthonormal. A lattice is searched without a search
/// structure: the points near x follow from x's coordinates in the plane.
struct SampleLattice {
  Vec3r center = Vec3r::Zero(), axisU = Vec3r::UnitX(), axisV = Vec3r::UnitY();
  Real halfU = 0, halfV = 0;
  long intervalsU = 1, intervalsV = 1;
  long firstU = 0, lastU = 0, firstV = 0, lastV = 0;

  /// The full lattice of a rectangle, spacing at most maxGap along each axis.
  static SampleLattice rectangle(const Vec3r& center, const Vec3r& axisU, const Vec3r& axisV, Real halfU, Real halfV,
                                 Real maxGap) {
    SampleLattice lattice;
    lattice.center = center;
    lattice.axisU = axisU;
    lattice.axisV = axisV;
    lattice.halfU = halfU;
    lattice.halfV = halfV;
    lattice.intervalsU = lattice.lastU = rectangleIntervals(halfU, maxGap);
    lattice.intervalsV = lattice.lastV = rectangleIntervals(halfV, maxGap);
    return lattice;
  }

  long countU() const { return std::max(0L, lastU - firstU + 1); }
  long countV() const { return std::max(0L, lastV - firstV + 1); }
  std::size_t size() const { return std::size_t(countU()) * std::size_t(countV()); }

  Vec3r point(long i, long j) const {
    const Real s = -halfU + 2 * halfU * Real(i) / Real(intervalsU);
    const Real t = -halfV + 2 * halfV * Real(j) / Real(intervalsV);
    return center + s * axisU + t * axisV;
  }
  /// Index of point (i, j) among this lattice's points in append() order.
  std::size_t offset(long i, long j) const { return std::size_t(j - firstV) * std::size_t(countU()) + std::size_t(i - firstU); }

  /// Appends the points, row by row (j outer, i inner).
  void append(std::vector<Vec3r>& samples) const {
    samples.reserve(samples.size() + size());
    for (long j = firstV; j <= lastV; ++j)
      for (long i = firstU; i <= lastU; ++i) samples.push_back(point(i, j));
  }
};

/// Points on the rectangle center + s u + t v, |s| <= halfU, |t| <= halfV, on a
/// grid whose spacing along each axis is at most maxGap (edges included).
inline void sampleRectangle(const Vec3r& center, const Vec3r& axisU, const Vec3r& axisV, Real halfU, Real halfV,
                            Real maxGap, std::vector<Vec3r>& samples) {
  SampleLattice::rectangle(center, axisU, axisV, halfU, halfV, maxGap).append(samples);
}

/// Removes samples closer than `tolerance` to an earlier one (keeps first occurrences, in
/// order); `kept` (if given) receives the indices of the samples kept.
void removeDuplicateSamples(std::vector<Vec3r>& samples, Real tolerance, std::vector<std::size_t>* kept = nullptr);

} // namespace cascade
