/// @file ParticleGrid.h
/// @brief Particles binned into a uniform grid of cubic cells, for fixed-radius
///        neighbour queries and for gathering particles near a block of voxels.
///
/// Particles are sorted by cell (key = packed cell coordinates, ties by index,
/// so the order is deterministic). Cells sorted by (x, y, z) form columns of
/// equal (x, y); a flat open-addressing hash table maps a column's (x, y) to its
/// run of cells, searched by z. A query with radius <= cellSize visits the 27
/// cells around a point: 9 column look-ups. Plain counting-sort cell grid as in Green 2010,
/// "Particle Simulation using CUDA" (NVIDIA whitepaper).
#pragma once

#include "libsph/Types.h"

#include <cstdint>
#include <utility>
#include <vector>

namespace cascade::surfacing {

class ParticleGrid {
public:
  using Coord = Eigen::Vector3i;

  /// Bins `positions` into cells of edge `cellSize` (m). Throws InputError if
  /// a position is not finite or the particles span more than 2^20 cells.
  ParticleGrid(const std::vector<Vec3r>& positions, double cellSize);

  double cellSize() const { return mCellSize; }
  std::size_t cellCount() const { return mCellCoords.size(); }

  /// Cell coordinates of a point.
  Coord cellOf(const Vec3r& point) const;
  /// Coordinates of cell number `cell` (cells are in key order).
  const Coord& cellCoord(std::size_t cell) const { return mCellCoords[cell]; }
  /// Index of the cell at `coord`, or -1 if it holds no particle.
  std::int64_t findCell(const Coord& coord) const;
  /// Range [begin, end) into sortedIndex()/sortedPosition() of cell `cell`.
  std::pair<std::uint32_t, std::uint32_t> cellRange(std::size_t cell) const {
    return {mCellStart[cell], mCellStart[cell + 1]};
  }
  /// Original particle index of sorted slot k (cells in order, ascending index within a cell).
  const std::vector<std::uint32_t>& sortedIndex() const { return mSortedIndex; }
  /// Positions in sorted order.
  const std::vector<Vec3r>& sortedPosition() const { return mSortedPosition; }

  /// Calls f(cell) for every non-empty cell of the 3x3x3 block around `coord`, in
  /// (x, y, z) order: per neighbour column one hash look-up, then its cells of
  /// z - 1 to z + 1, which are consecutive (cells are sorted by (x, y, z)).
  template <class F>
  void forEachNeighborCell(const Coord& coord, F&& f) const {
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy) {
        const std::int64_t column = findColumn(coord.x() + dx, coord.y() + dy);
        if (column < 0) continue;
        std::uint32_t cell = firstCellFrom(std::size_t(column), coord.z() - 1);
        const std::uint32_t end = mColumnStart[std::size_t(column) + 1];
        for (; cell < end && mCellCoords[cell].z() <= coord.z() + 1; ++cell) f(std::size_t(cell));
      }
  }

  /// Calls f(k) for every sorted slot k whose cell is within `ring` cells of `coord`.
  template <class F>
  void forEachInNeighborCells(const Coord& coord, F&& f, int ring = 1) const {
    if (ring == 1) {
      forEachNeighborCell(coord, [&](std::size_t cell) {
        for (std::uint32_t k = mCellStart[cell]; k < mCellStart[cell + 1]; ++k) f(k);
      });
      return;
    }
    for (int dx = -ring; dx <= ring; ++dx)
      for (int dy = -ring; dy <= ring; ++dy)
        for (int dz = -ring; dz <= ring; ++dz) {
          const std::int64_t cell = findCell(coord + Coord(dx, dy, dz));
          if (cell < 0) continue;
          for (std::uint32_t k = mCellStart[cell]; k < mCellStart[cell + 1]; ++k) f(k);
        }
  }

private:
  /// Index of the column of cells at (x, y), or -1 if it has none.
  std::int64_t findColumn(int x, int y) const {
    const std::uint64_t key = columnKeyOf(x, y);
    if (key == kNoColumn || mTable.empty()) return -1;
    for (std::uint64_t slot = hashColumn(key) & mTableMask;; slot = (slot + 1) & mTableMask) {
      const ColumnSlot& entry = mTable[slot];
      if (entry.key == key) return std::int64_t(entry.column);
      if (entry.key == kNoColumn) return -1;
    }
  }
  /// First cell of `column` with z >= `z` (or the column's end).
  std::uint32_t firstCellFrom(std::size_t column, int z) const {
    std::uint32_t cell = mColumnStart[column];
    const std::uint32_t end = mColumnStart[column + 1];
    if (end - cell > 8) {  // a deep column: binary search
      std::uint32_t count = end - cell;
      while (count > 0) {
        const std::uint32_t half = count / 2;
        if (mCellCoords[cell + half].z() < z) cell += half + 1, count -= half + 1;
        else count = half;
      }
      return cell;
    }
    while (cell < end && mCellCoords[cell].z() < z) ++cell;
    return cell;
  }
  std::uint64_t columnKeyOf(int x, int y) const {
    const std::int64_t cx = std::int64_t(x) - mOrigin.x(), cy = std::int64_t(y) - mOrigin.y();
    if (cx < 0 || cy < 0 || cx >= (std::int64_t(1) << 21) || cy >= (std::int64_t(1) << 21)) return kNoColumn;
    return (std::uint64_t(cx) << 21) | std::uint64_t(cy);
  }
  /// splitmix64's finaliser: every key bit reaches the low bits the table uses.
  static std::uint64_t hashColumn(std::uint64_t key) {
    key = (key ^ (key >> 30)) * 0xBF58476D1CE4E5B9ull;
    key = (key ^ (key >> 27)) * 0x94D049BB133111EBull;
    return key ^ (key >> 31);
  }
  static constexpr std::uint64_t kNoColumn = ~std::uint64_t(0);
  struct ColumnSlot {
    std::uint64_t key = kNoColumn;
    std::uint64_t column = 0;
  };

  double mCellSize;
  Coord mOrigin = Coord::Zero();  // cell coordinates are offset by this for keys
  std::vector<Coord> mCellCoords;
  std::vector<std::uint32_t> mCellStart;
  std::vector<std::uint32_t> mSortedIndex;
  std::vector<Vec3r> mSortedPosition;
  std::vector<std::uint32_t> mColumnStart;  // first cell of each column, then the cell count
  std::vector<ColumnSlot> mTable;            // open addressing: column (x, y) -> column index
  std::uint64_t mTableMask = 0;
};

/// Median nearest-neighbour distance of (a deterministic sample of) the
/// particles, rounded to two significant digits so that frames of one bake give
/// the same value; 0 if there are fewer than two particles.
double estimateParticleSpacing(const std::vector<Vec3r>& positions);

} // namespace cascade::surfacing
