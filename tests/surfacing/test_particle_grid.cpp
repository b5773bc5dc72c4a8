// Surfacing's neighbour search: ParticleGrid's cell order and 27-cell
// neighbourhoods, and the AVX2 and scalar distance tests of
// surfacing/detail/NeighborsWithin.h, against brute force.
#include "surfacing/ParticleGrid.h"
#include "surfacing/detail/NeighborsWithin.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <tuple>
#include <vector>

namespace {

using cascade::Real;
using cascade::Vec3r;
using cascade::surfacing::ParticleGrid;

/// A dense block, a sparse cloud (most cells alone, as airborne droplets) and
/// points on negative coordinates and exactly on cell faces.
std::vector<Vec3r> mixedPoints(double cell) {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<Vec3r> points;
  for (int i = 0; i < 3000; ++i)
    points.emplace_back(Real(-0.3 * cell + 4 * cell * unit(random)), Real(2 * cell * unit(random)),
                        Real(-5 * cell + 3 * cell * unit(random)));
  for (int i = 0; i < 400; ++i)
    points.emplace_back(Real(-40 * cell + 80 * cell * unit(random)), Real(-40 * cell + 80 * cell * unit(random)),
                        Real(-40 * cell + 80 * cell * unit(random)));
  for (int i = -3; i <= 3; ++i) points.emplace_back(Real(i * cell), Real(-i * cell), Real(2 * i * cell));
  return points;
}

TEST(SurfaceParticleGrid, CellsSortedAndNeighbourCellsExact) {
  const double cell = 0.1;
  const std::vector<Vec3r> points = mixedPoints(cell);
  const ParticleGrid grid(points, cell);
  // Slots hold every particle once, cells in (x, y, z) order, indices ascending within a cell.
  std::vector<std::uint32_t> seen(grid.sortedIndex());
  std::sort(seen.begin(), seen.end());
  for (std::size_t i = 0; i < points.size(); ++i) ASSERT_EQ(seen[i], i);
  for (std::size_t c = 0; c < grid.cellCount(); ++c) {
    const auto coord = grid.cellCoord(c);
    if (c > 0) {
      const auto previous = grid.cellCoord(c - 1);
      EXPECT_LT(std::make_tuple(previous.x(), previous.y(), previous.z()), std::make_tuple(coord.x(), coord.y(), coord.z()));
    }
    const auto [begin, end] = grid.cellRange(c);
    for (std::uint32_t k = begin; k < end; ++k) {
      EXPECT_EQ(grid.cellOf(points[grid.sortedIndex()[k]]), coord);
      EXPECT_EQ(grid.sortedPosition()[k], points[grid.sortedIndex()[k]]);
      if (k > begin) {
        EXPECT_LT(grid.sortedIndex()[k - 1], grid.sortedIndex()[k]);
      }
    }
    EXPECT_EQ(grid.findCell(coord), std::int64_t(c));
  }
  EXPECT_EQ(grid.findCell(grid.cellCoord(0) + ParticleGrid::Coord(0, 0, -1)), -1);
  // The 27 cells around every particle's cell hold exactly the particles whose cells are that close.
  for (std::size_t i = 0; i < points.size(); i += 7) {
    const ParticleGrid::Coord home = grid.cellOf(points[i]);
    std::vector<std::uint32_t> found, expected;
    grid.forEachInNeighborCells(home, [&](std::uint32_t k) { found.push_back(grid.sortedIndex()[k]); });
    for (std::size_t j = 0; j < points.size(); ++j)
      if (((grid.cellOf(points[j]) - home).array().abs() <= 1).all()) expected.push_back(std::uint32_t(j));
    std::sort(found.begin(), found.end());
    ASSERT_EQ(found, expected) << "particle " << i;
  }
}

TEST(SurfaceNeighborsWithin, Avx2AndScalarMatchBruteForce) {
  using namespace cascade::surfacing::detail;
  std::mt19937 random(11);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  const std::size_t pad = kNeighborsWithinPadding;
  for (std::size_t count : {0, 1, 7, 8, 9, 31, 200, 257}) {
    std::vector<float> x(count + pad), y(count + pad), z(count + pad);
    std::vector<std::uint32_t> ids(count + pad);
    for (std::size_t c = 0; c < count + pad; ++c) {
      x[c] = unit(random), y[c] = unit(random), z[c] = unit(random);
      ids[c] = std::uint32_t(1000 + c);
    }
    const float px = 0.1f, py = -0.2f, pz = 0.05f, radius2 = 0.5f;
    const std::uint32_t self = count > 3 ? ids[3] : 0;
    if (count > 3) x[3] = px, y[3] = py, z[3] = pz;  // the particle itself: left out
    std::vector<std::uint32_t> expected;
    std::vector<float> expectedR2;
    for (std::size_t c = 0; c < count; ++c) {
      const float ox = x[c] - px, oy = y[c] - py, oz = z[c] - pz;
      const float r2 = ox * ox + oy * oy + oz * oz;
      if (r2 < radius2 && ids[c] != self) expected.push_back(std::uint32_t(c)), expectedR2.push_back(r2);
    }
    std::vector<std::uint32_t> within(count + pad);
    std::vector<float> r2(count + pad);
    const std::size_t scalar =
        neighborsWithinScalar(x.data(), y.data(), z.data(), ids.data(), count, px, py, pz, radius2, self, within.data(), r2.data());
    ASSERT_EQ(std::vector<std::uint32_t>(within.begin(), within.begin() + scalar), expected);
    ASSERT_EQ(std::vector<float>(r2.begin(), r2.begin() + scalar), expectedR2);
#ifdef CASCADE_NEIGHBORS_WITHIN_AVX2
    if (!__builtin_cpu_supports("avx2")) continue;
    std::fill(within.begin(), within.end(), 0u);
    const std::size_t simd =
        neighborsWithinAvx2(x.data(), y.data(), z.data(), ids.data(), count, px, py, pz, radius2, self, within.data(), r2.data());
    ASSERT_EQ(std::vector<std::uint32_t>(within.begin(), within.begin() + simd), expected) << count << " candidates";
    ASSERT_EQ(std::vector<float>(r2.begin(), r2.begin() + simd), expectedR2);  // bit for bit
#endif
  }
}

} // namespace
