#include "libsph/solver/CoarseCorrection.h"

#include "libsph/solver/ParallelSum.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace cascade {

namespace {
constexpr int kSlots = 27;
// Fixed chunks of particles for the sums (the chunking, not the threads, sets the order).
constexpr std::size_t kChunks = 8, kMinChunk = 8192;  // an aggregate's neighbouring cells, (dz, dy, dx) in {-1, 0, 1}^3
int slotOf(const std::int32_t* a, const std::int32_t* b) {
  return (b[2] - a[2] + 1) * 9 + (b[1] - a[1] + 1) * 3 + (b[0] - a[0] + 1);
}
} // namespace

bool CoarseCorrection::aggregate(const Vec3r* position, const std::vector<double>& scaling, Real cellSize) {
  const std::size_t n = scaling.size();
  mAggregate.assign(n, -1);
  mCell.clear();
  mCount = 0;
  Vec3d lo = Vec3d::Constant(std::numeric_limits<double>::max()), hi = -lo;
  for (std::size_t i = 0; i < n; ++i)
    if (scaling[i] > 0 && position[i].allFinite()) {
      lo = lo.cwiseMin(position[i].cast<double>());
      hi = hi.cwiseMax(position[i].cast<double>());
    }
  if (!(lo.x() <= hi.x())) return false;
  const double inverse = 1.0 / double(cellSize);
  std::int64_t dims[3];
  for (int a = 0; a < 3; ++a) dims[a] = std::int64_t(std::floor((hi[a] - lo[a]) * inverse)) + 1;
  const std::int64_t cells = dims[0] * dims[1] * dims[2];
  if (cells > std::int64_t(8 * n + (1 << 20))) return false;  // sparse spray: no dense grid
  std::vector<std::int32_t> cellOf(n, -1);
  std::vector<std::int32_t> idOfCell(std::size_t(cells), -1);
  for (std::size_t i = 0; i < n; ++i) {
    if (!(scaling[i] > 0) || !position[i].allFinite()) continue;
    std::int64_t c[3];
    for (int a = 0; a < 3; ++a)
      c[a] = std::clamp<std::int64_t>(std::int64_t(std::floor((double(position[i][a]) - lo[a]) * inverse)), 0, dims[a] - 1);
    const std::int64_t linear = (c[2] * dims[1] + c[1]) * dims[0] + c[0];
    cellOf[i] = std::int32_t(linear);
    idOfCell[std::size_t(linear)] = 0;
  }
  for (std::int64_t linear = 0; linear < cells; ++linear) {
    if (idOfCell[std::size_t(linear)] < 0) continue;
    idOfCell[std::size_t(linear)] = std::int32_t(mCount++);
    mCell.push_back(std::int32_t(linear % dims[0]));
    mCell.push_back(std::int32_t((linear / dims[0]) % dims[1]));
    mCell.push_back(std::int32_t(linear / (dims[0] * dims[1])));
  }
  for (std::size_t i = 0; i < n; ++i)
    if (cellOf[i] >= 0) mAggregate[i] = idOfCell[std::size_t(cellOf[i])];
  mWeight.resize(n);
  for (std::size_t i = 0; i < n; ++i) mWeight[i] = mAggregate[i] >= 0 ? 1.0 / scaling[i] : 0.0;
  return mCount > 0;
}

bool CoarseCorrection::build(const Vec3r* position, const std::vector<double>& scaling, Real cellSize, double dt2,
                             const RowOf& rowOf) {
  mActive = false;
  if (!aggregate(position, scaling, cellSize)) return false;
  const std::size_t n = scaling.size();
  // Lower triangle of A_c, by column: entry (max(c, d), min(c, d)) in a slot of min's
  // column. Fixed chunks of particles (at most kChunks, whatever the threads), each with
  // its own entries, added in chunk order: the same bits on any number of threads.
  const std::size_t chunkSize = std::max<std::size_t>(kMinChunk, (n + kChunks - 1) / kChunks);
  const std::size_t chunks = (n + chunkSize - 1) / chunkSize;
  std::vector<std::vector<double>> partial(chunks);
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t chunk) {
    std::vector<double>& entries = partial[chunk];
    entries.assign(mCount * kSlots, 0.0);
    std::vector<Coefficient> row;
    std::vector<std::pair<std::int32_t, Vec3d>> touched;
    const std::size_t end = std::min(n, (chunk + 1) * chunkSize);
    for (std::size_t k = chunk * chunkSize; k < end; ++k) {
      row.clear();
      rowOf(k, row);
      touched.clear();
      for (const Coefficient& c : row) {
        if (c.source >= n) continue;
        const std::int32_t a = mAggregate[c.source];
        if (a < 0) continue;
        auto at = std::find_if(touched.begin(), touched.end(), [a](const auto& t) { return t.first == a; });
        if (at == touched.end())
          touched.emplace_back(a, c.change.cast<double>());
        else
          at->second += c.change.cast<double>();
      }
      for (std::size_t p = 0; p < touched.size(); ++p)
        for (std::size_t q = p; q < touched.size(); ++q) {
          std::int32_t a = touched[p].first, b = touched[q].first;
          if (b < a) std::swap(a, b);
          const int slot = slotOf(&mCell[3 * std::size_t(a)], &mCell[3 * std::size_t(b)]);
          if (slot < 0 || slot >= kSlots) continue;  // beyond the next cell: no coupling (cell >= 2 h)
          entries[std::size_t(a) * kSlots + std::size_t(slot)] += dt2 * touched[p].second.dot(touched[q].second);
        }
    }
  });
  std::vector<double>& entries = partial[0];
  tbb::parallel_for(std::size_t(0), entries.size(), [&](std::size_t e) {
    for (std::size_t chunk = 1; chunk < chunks; ++chunk) entries[e] += partial[chunk][e];
  });
  // A_c from the slots, with a shift of 1e-10 of the mean diagonal (water with no free
  // surface has the constant stiffness as a null vector); nothing to correct: no A_c.
  double trace = 0;
  for (std::size_t a = 0; a < mCount; ++a) trace += entries[a * kSlots + 13];
  if (!(trace > 0) || !std::isfinite(trace)) return false;
  const double shift = 1e-10 * trace / double(mCount);
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(mCount * 14);
  // The aggregate of a cell: ids follow the cells' (z, y, x) order, so a binary search.
  auto findAggregate = [&](std::int32_t x, std::int32_t y, std::int32_t z) -> std::int64_t {
    std::size_t lo = 0, hi = mCount;
    while (lo < hi) {
      const std::size_t mid = (lo + hi) / 2;
      const std::int32_t* c = &mCell[3 * mid];
      const bool less = c[2] != z ? c[2] < z : c[1] != y ? c[1] < y : c[0] < x;
      if (less)
        lo = mid + 1;
      else
        hi = mid;
    }
    if (lo < mCount && mCell[3 * lo] == x && mCell[3 * lo + 1] == y && mCell[3 * lo + 2] == z) return std::int64_t(lo);
    return -1;
  };
  for (std::size_t a = 0; a < mCount; ++a) {
    const std::int32_t* c = &mCell[3 * a];
    for (int slot = 0; slot < kSlots; ++slot) {
      const double value = entries[a * kSlots + std::size_t(slot)];
      if (slot == 13) {
        triplets.emplace_back(int(a), int(a), value + shift);
        continue;
      }
      if (value == 0) continue;
      const std::int64_t b = findAggregate(c[0] + slot % 3 - 1, c[1] + (slot / 3) % 3 - 1, c[2] + slot / 9 - 1);
      if (b > std::int64_t(a)) triplets.emplace_back(int(b), int(a), value);
    }
  }
  Eigen::SparseMatrix<double> coarse{Eigen::Index(mCount), Eigen::Index(mCount)};
  coarse.setFromTriplets(triplets.begin(), triplets.end());
  mSolver.compute(coarse);
  if (mSolver.info() != Eigen::Success) return false;
  mActive = true;
  return true;
}

void CoarseCorrection::apply(std::vector<double>& z, const std::vector<char>& bound) const {
  if (!mActive) return;
  const std::size_t n = z.size();
  // Z^^T r in fixed chunks (as build()), then A_c^-1, then z += Z^ y.
  const std::size_t chunkSize = std::max<std::size_t>(kMinChunk, (n + kChunks - 1) / kChunks);
  const std::size_t chunks = (n + chunkSize - 1) / chunkSize;
  mPartial.resize(chunks);
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t chunk) {
    Eigen::VectorXd& sums = mPartial[chunk];
    sums.setZero(Eigen::Index(mCount));
    const std::size_t end = std::min(n, (chunk + 1) * chunkSize);
    for (std::size_t i = chunk * chunkSize; i < end; ++i)
      if (!bound[i] && mAggregate[i] >= 0) sums[mAggregate[i]] += mWeight[i] * z[i];
  });
  for (std::size_t chunk = 1; chunk < chunks; ++chunk) mPartial[0] += mPartial[chunk];
  mCoarse = mSolver.solve(mPartial[0]);
  forEachIndex(n, [&](std::size_t i) {
    if (!bound[i] && mAggregate[i] >= 0) z[i] += mWeight[i] * mCoarse[mAggregate[i]];
  });
}

} // namespace cascade
