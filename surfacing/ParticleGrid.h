/// @file ParticleGrid.h
/// @brief Particles binned into a uniform grid of cubic cells, for fixed-radius
///        neighbour queries and for gathering particles near a block of voxels.
///
/// Particles are sorted by cell (key = packed cell coordinates, ties by index,
/// so the order is deterministic) and a flat open-addressing hash table maps a
/// cell's coordinates to its range. A query with radius <= cellSize visits the
/// 27 cells around a point. Plain counting-sort cell grid as in Green 2010,
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
  /// (x, y, z) order. Cells are sorted by (x, y, z), so a z column's cells are
  /// consecutive: after a hit, the next z is the next cell or absent (no lookup).
  template <class F>
  void forEachNeighborCell(const Coord& coord, F&& f) const {
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy) {
        std::int64_t previous = -1;
        for (int dz = -1; dz <= 1; ++dz) {
          const Coord target(coord.x() + dx, coord.y() + dy, coord.z() + dz);
          std::int64_t cell;
          if (previous >= 0) {
            const std::size_t next = std::size_t(previous) + 1;
            cell = next < mCellCoords.size() && mCellCoords[next] == target ? std::int64_t(next) : -1;
          } else {
            cell = findCell(target);
          }
          if (cell >= 0) f(std::size_t(cell));
          previous = cell;
        }
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
  std::uint64_t keyOf(const Coord& coord) const;

  double mCellSize;
  Coord mOrigin = Coord::Zero();  // cell coordinates are offset by this for keys
  std::vector<Coord> mCellCoords;
  std::vector<std::uint32_t> mCellStart;
  std::vector<std::uint32_t> mSortedIndex;
  std::vector<Vec3r> mSortedPosition;
  std::vector<std::int64_t> mTable;  // open addressing: cell index or -1
  std::vector<std::uint64_t> mTableKey;
  std::uint64_t mTableMask = 0;
};

/// Median nearest-neighbour distance of (a deterministic sample of) the
/// particles, rounded to two significant digits so that frames of one bake give
/// the same value; 0 if there are fewer than two particles.
double estimateParticleSpacing(const std::vector<Vec3r>& positions);

} // namespace cascade::surfacing
