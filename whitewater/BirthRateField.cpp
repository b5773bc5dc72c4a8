// A frame's birth rates as a field of cells (BirthRateField.h).
#include "whitewater/BirthRateField.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace cascade::whitewater {

BirthRateField::Cell* BirthRateField::find(std::uint64_t key, bool insert) {
  for (std::uint64_t slot = hash(key) & mMask;; slot = (slot + 1) & mMask) {
    Cell& cell = mCells[slot];
    if (cell.key == key) return &cell;
    if (cell.key == 0) {
      if (!insert) return nullptr;
      cell.key = key;
      ++mUsed;
      return &cell;
    }
  }
}

void BirthRateField::build(const Vec3r* positions, const float* rates, std::size_t count, Real cellSize) {
  mInverseCell = 1.0 / double(cellSize);
  mUsed = 0;
  std::size_t sources = 0;
  for (std::size_t i = 0; i < count; ++i) sources += rates[i] > 0;
  if (sources == 0) {
    mCells.clear();
    mMask = 0;
    return;
  }
  // At most half full.
  std::size_t capacity = 16;
  while (capacity < 2 * sources) capacity *= 2;
  mCells.assign(capacity, Cell{});
  mMask = capacity - 1;
  mLow = Vec3r::Constant(std::numeric_limits<Real>::max());
  mHigh = Vec3r::Constant(std::numeric_limits<Real>::lowest());
  for (std::size_t i = 0; i < count; ++i)
    if (rates[i] > 0) {
      find(keyOf(positions[i]), true)->rate += rates[i];
      mLow = mLow.cwiseMin(positions[i]);
      mHigh = mHigh.cwiseMax(positions[i]);
    }
  // Grown to whole cells (and a cell more, for rounding): a point outside has no rate.
  for (int axis = 0; axis < 3; ++axis) {
    mLow[axis] = (std::floor(mLow[axis] / cellSize) - 1) * cellSize;
    mHigh[axis] = (std::floor(mHigh[axis] / cellSize) + 2) * cellSize;
  }
  // Every particle in a cell with a rate counts, a rate or not: the mean is per particle there.
  for (std::size_t i = 0; i < count; ++i)
    if (Cell* cell = find(keyOf(positions[i]), false)) ++cell->count;
  for (Cell& cell : mCells)
    if (cell.key != 0) cell.rate /= float(cell.count);
}

} // namespace cascade::whitewater
