#include "surfacing/ParticleGrid.h"

#include "libsph/Errors.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <utility>

namespace cascade::surfacing {

namespace {
constexpr int kKeyBits = 21;
constexpr std::int64_t kKeyRange = std::int64_t(1) << kKeyBits;

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

  // Sort by cell, ties by index: a stable LSD radix sort (11-bit digits) of the
  // dense cell number ((x * ny) + y) * nz + z over the bounds, whose order is the
  // (x, y, z) order of the cells.
  const Eigen::Matrix<std::uint64_t, 3, 1> extent = (hi - lo).cast<std::uint64_t>().array() + 1;
  std::vector<std::uint64_t> key(n), keyScratch(n);
  std::vector<std::uint32_t> order(n), orderScratch(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const Eigen::Matrix<std::uint64_t, 3, 1> c = (coords[i] - lo).cast<std::uint64_t>();
      key[i] = (c.x() * extent.y() + c.y()) * extent.z() + c.z();
      order[i] = std::uint32_t(i);
    }
  });
  const std::uint64_t largestKey = extent.prod() - 1;  // < 2^63: every extent is below 2^21
  constexpr int kDigitBits = 11;
  constexpr std::size_t kDigits = std::size_t(1) << kDigitBits;
  for (int shift = 0; shift < 64 && (largestKey >> shift) != 0; shift += kDigitBits) {
    std::vector<std::uint32_t> next(kDigits, 0);
    for (std::size_t i = 0; i < n; ++i) ++next[(key[i] >> shift) & (kDigits - 1)];
    std::uint32_t total = 0;
    for (std::uint32_t& slot : next) total += std::exchange(slot, total);
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint32_t to = next[(key[i] >> shift) & (kDigits - 1)]++;
      keyScratch[to] = key[i];
      orderScratch[to] = order[i];
    }
    key.swap(keyScratch);
    order.swap(orderScratch);
  }

  mSortedIndex = std::move(order);
  mSortedPosition.resize(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& range) {
    for (std::size_t k = range.begin(); k != range.end(); ++k) mSortedPosition[k] = positions[mSortedIndex[k]];
  });
  for (std::size_t k = 0; k < n; ++k) {
    if (k == 0 || key[k] != key[k - 1]) {
      mCellStart.push_back(std::uint32_t(k));
      mCellCoords.push_back(coords[mSortedIndex[k]]);
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
