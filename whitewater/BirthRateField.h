/// @file BirthRateField.h
/// @brief A frame's birth rates (Ihmsen et al. 2012, eq. 7) as a field in space:
///        the mean rate of the frame's fluid particles in each cell of a grid.
///
/// The caches sample the potentials only at frame times. Carried by the
/// particles that had them there, a source that stays in place (the foot of a
/// slope, a jet's impact) gives births only to the particles that happen to
/// sit on it at a frame time: in the flow they are a row of separate points,
/// one frame's travel apart, and the foam they make floats off in stripes.
/// As a field, the rate belongs to the place: between frames every particle
/// that passes a source that stays gives birth while it is there
/// (WhitewaterSolver::advance says which sources stay and how the frames are
/// blended). With cells of one spacing (about a particle each), a flow that
/// keeps its particles' spacing keeps the total rate.
#pragma once

#include "libsph/Types.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace cascade::whitewater {

class BirthRateField {
public:
  /// The field of `count` particles at `positions` with birth rates `rates`
  /// (per second; 0 for most), in cells of edge `cellSize` (world aligned).
  void build(const Vec3r* positions, const float* rates, std::size_t count, Real cellSize);

  /// No particle has a rate: every lookup gives 0.
  bool empty() const { return mUsed == 0; }

  /// The mean rate of the particles that were in the cell of x (0 where none had one).
  float at(const Vec3r& x) const {
    if (mUsed == 0 || !(x.x() >= mLow.x() && x.y() >= mLow.y() && x.z() >= mLow.z() && x.x() < mHigh.x() &&
                        x.y() < mHigh.y() && x.z() < mHigh.z()))
      return 0.0f;
    const std::uint64_t key = keyOf(x);
    for (std::uint64_t slot = hash(key) & mMask;; slot = (slot + 1) & mMask) {
      const Cell& cell = mCells[slot];
      if (cell.key == key) return cell.rate;
      if (cell.key == 0) return 0.0f;
    }
  }

private:
  struct Cell {
    std::uint64_t key = 0;  ///< 0: empty
    float rate = 0;         ///< the sum of the rates, then their mean
    std::uint32_t count = 0;
  };
  /// 21 bits an axis around the origin (cells of a spacing: +-5 km at 5 mm);
  /// farther points share the border cells. Never 0 (the empty key).
  std::uint64_t keyOf(const Vec3r& x) const {
    std::uint64_t key = 0;
    for (int axis = 0; axis < 3; ++axis) {
      const double cell = std::floor(double(x[axis]) * mInverseCell) + double(1 << 20);
      key = (key << 21) | std::uint64_t(std::clamp(cell, 1.0, double((1 << 21) - 1)));
    }
    return key;
  }
  static std::uint64_t hash(std::uint64_t key) { return (key * 0x9E3779B97F4A7C15ull) >> 20; }
  Cell* find(std::uint64_t key, bool insert);

  double mInverseCell = 1;
  Vec3r mLow = Vec3r::Zero(), mHigh = Vec3r::Zero();  ///< the box of the cells with a rate
  std::vector<Cell> mCells;
  std::uint64_t mMask = 0;
  std::size_t mUsed = 0;
};

} // namespace cascade::whitewater
