#include "surfacing/ParticleGrid.h"

#include "libsph/Errors.h"

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace cascade::surfacing {

namespace {
constexpr int kKeyBits = 21;
constexpr std::int64_t kKeyRange = std::int64_t(1) << kKeyBits;
constexpr std::uint64_t kNoKey = std::numeric_limits<std::uint64_t>::max();

} // namespace

ParticleGrid::ParticleGrid(const std::vector<Vec3r>& positions, double cellSize)
    : mCellSize(cellSize) {
  const std::size_t n = positions.size();
  if (n >= std::numeric_limits<std::uint32_t>::max())
    throw InputError("surfacing: too many particles in one frame");
  if (n == 0) {
    mCellStart.push_back(0);
    return;
  }
  // Cell coordinates and their bounds.
  std::vector<Coord> coords(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const Vec3r& p = positions[i];
      if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z())) {
        std::ostringstream message;
        message << "particle " << i << " has a non-finite position";
        throw InputError(message.str());
      }
      coords[i] = cellOf(p);
    }
  });
  Coord lo = coords[0], hi = coords[0];
  for (const Coord& c : coords) {
    lo = lo.cwiseMin(c);
    hi = hi.cwiseMax(c);
  }
  if (((hi - lo).cast<std::int64_t>().array() >= kKeyRange - 2).any())
    throw InputError("particles span more than 2^21 cells of the surfacing grid along an axis");
  mOrigin = lo - Coord::Ones();  // keep neighbours of border cells in range

  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i)
      keyed[i] = {keyOf(coords[i]), std::uint32_t(i)};
  });
  tbb::parallel_sort(keyed.begin(), keyed.end());

  mSortedIndex.resize(n);
  mSortedPosition.resize(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& range) {
    for (std::size_t k = range.begin(); k != range.end(); ++k) {
      mSortedIndex[k] = keyed[k].second;
      mSortedPosition[k] = positions[keyed[k].second];
    }
  });
  for (std::size_t k = 0; k < n; ++k) {
    if (k == 0 || keyed[k].first != keyed[k - 1].first) {
      mCellStart.push_back(std::uint32_t(k));
      mCellCoords.push_back(coords[keyed[k].second]);
    }
  }
  mCellStart.push_back(std::uint32_t(n));

  // Columns (runs of cells of equal x, y) and their hash table, load factor <= 1/2.
  for (std::size_t cell = 0; cell < mCellCoords.size(); ++cell)
    if (cell == 0 || mCellCoords[cell].x() != mCellCoords[cell - 1].x() ||
        mCellCoords[cell].y() != mCellCoords[cell - 1].y())
      mColumnStart.push_back(std::uint32_t(cell));
  const std::size_t columns = mColumnStart.size();
  mColumnStart.push_back(std::uint32_t(mCellCoords.size()));
  std::size_t tableSize = 16;
  while (tableSize < 2 * columns) tableSize *= 2;
  mTable.assign(tableSize, ColumnSlot{});
  mTableMask = tableSize - 1;
  for (std::size_t column = 0; column < columns; ++column) {
    const Coord& first = mCellCoords[mColumnStart[column]];
    const std::uint64_t key = columnKeyOf(first.x(), first.y());
    std::uint64_t slot = hashColumn(key) & mTableMask;
    while (mTable[slot].key != kNoColumn) slot = (slot + 1) & mTableMask;
    mTable[slot] = {key, column};
  }
}

ParticleGrid::Coord ParticleGrid::cellOf(const Vec3r& point) const {
  const double inverse = 1.0 / mCellSize;
  return Coord(int(std::floor(double(point.x()) * inverse)), int(std::floor(double(point.y()) * inverse)),
               int(std::floor(double(point.z()) * inverse)));
}

std::uint64_t ParticleGrid::keyOf(const Coord& coord) const {
  const Eigen::Matrix<std::int64_t, 3, 1> c = (coord - mOrigin).cast<std::int64_t>();
  if ((c.array() < 0).any() || (c.array() >= kKeyRange).any()) return kNoKey;
  return (std::uint64_t(c.x()) << (2 * kKeyBits)) | (std::uint64_t(c.y()) << kKeyBits) | std::uint64_t(c.z());
}

std::int64_t ParticleGrid::findCell(const Coord& coord) const {
  if (mTable.empty()) return -1;
  const std::int64_t column = findColumn(coord.x(), coord.y());
  if (column < 0) return -1;
  const std::uint32_t cell = firstCellFrom(std::size_t(column), coord.z());
  return cell < mColumnStart[std::size_t(column) + 1] && mCellCoords[cell].z() == coord.z() ? std::int64_t(cell) : -1;
}

double estimateParticleSpacing(const std::vector<Vec3r>& positions) {
  const std::size_t n = positions.size();
  if (n < 2) return 0;
  // Cell size from the bounding box, then grown until most samples find a neighbour.
  Vec3r lo = positions[0], hi = positions[0];
  for (const Vec3r& p : positions) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Vec3d extent = (hi - lo).cast<double>().cwiseMax(Vec3d::Constant(1e-9));
  double cell = std::cbrt(extent.prod() / double(n));
  cell = std::max({cell, extent.maxCoeff() * 1e-6, 1e-9});
  const std::size_t stride = std::max<std::size_t>(1, n / 20000);
  for (int attempt = 0; attempt < 40; ++attempt, cell *= 2) {
    ParticleGrid grid(positions, cell);
    std::vector<double> nearest;
    for (std::size_t i = 0; i < n; i += stride) {
      const Vec3r& p = positions[i];
      double best = std::numeric_limits<double>::infinity();
      grid.forEachInNeighborCells(grid.cellOf(p), [&](std::uint32_t k) {
        if (grid.sortedIndex()[k] == i) return;
        best = std::min(best, double((grid.sortedPosition()[k] - p).squaredNorm()));
      });
      if (best <= cell * cell) nearest.push_back(std::sqrt(best));
    }
    const std::size_t samples = (n + stride - 1) / stride;
    if (nearest.size() * 2 < samples) continue;  // most particles found no neighbour: grow
    std::nth_element(nearest.begin(), nearest.begin() + nearest.size() / 2, nearest.end());
    const double median = nearest[nearest.size() / 2];
    if (median <= 0) return 0;
    const double scale = std::pow(10.0, std::floor(std::log10(median)) - 1);
    return std::round(median / scale) * scale;
  }
  return 0;
}

} // namespace cascade::surfacing
