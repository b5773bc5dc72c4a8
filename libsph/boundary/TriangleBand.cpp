#include "libsph/boundary/TriangleBand.h"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>

namespace cascade {

Vec3d closestOnTriangle(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const Vec3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + (d1 / (d1 - d3)) * ab;
  const Vec3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

TriangleBand::TriangleBand(const std::vector<Vec3d>& a, const std::vector<Vec3d>& b, const std::vector<Vec3d>& c,
                           double range, double slack)
    : mA(a), mB(b), mC(c), mRange(range) {
  const std::size_t n = a.size();
  refit();
  Vec3d lo = Vec3d::Constant(1e300), hi = -lo;
  for (std::size_t t = 0; t < n; ++t) {
    lo = lo.cwiseMin(mBoxLo[t]);
    hi = hi.cwiseMax(mBoxHi[t]);
  }
  if (n == 0 || !(range > 0)) return;
  slack = std::max(slack, 0.0);
  const double margin = range + slack;  // the grid covers the bounds grown by this
  mCellSize = 0.5 * range;
  // At most ~8 M cells (a huge mesh with a tiny range): coarser cells stay correct.
  const Vec3d extent = hi - lo + Vec3d::Constant(2 * margin);
  const double cells = extent.x() * extent.y() * extent.z() / (mCellSize * mCellSize * mCellSize);
  if (cells > 8e6) mCellSize *= std::cbrt(cells / 8e6) * 1.001;
  mInverseCellSize = 1.0 / mCellSize;
  mOrigin = lo - Vec3d::Constant(margin);
  for (int k = 0; k < 3; ++k) mDims[k] = long(std::floor(extent[k] * mInverseCellSize)) + 1;
  const std::size_t cellCount = std::size_t(mDims[0]) * mDims[1] * mDims[2];
  const double reach = margin + 0.5 * std::sqrt(3.0) * mCellSize;

  // Per triangle, the cells it serves (in cell order), in parallel over triangles.
  // Isolated: the band may be built lazily inside a parallel query loop while
  // its owner holds a lock, and must not pick up that loop's other tasks.
  std::vector<std::vector<std::uint32_t>> cellsOf(n);
  tbb::this_task_arena::isolate([&] { tbb::parallel_for(std::size_t(0), n, [&](std::size_t t) {
    long l[3], u[3];
    for (int k = 0; k < 3; ++k) {
      l[k] = std::max(0L, long(std::floor((mBoxLo[t][k] - reach - mOrigin[k]) * mInverseCellSize)));
      u[k] = std::min(mDims[k] - 1, long(std::floor((mBoxHi[t][k] + reach - mOrigin[k]) * mInverseCellSize)));
    }
    for (long z = l[2]; z <= u[2]; ++z)
      for (long y = l[1]; y <= u[1]; ++y)
        for (long x = l[0]; x <= u[0]; ++x) {
          const Vec3d centre = mOrigin + mCellSize * Vec3d(x + 0.5, y + 0.5, z + 0.5);
          if ((closestOnTriangle(centre, a[t], b[t], c[t]) - centre).squaredNorm() <= reach * reach)
            cellsOf[t].push_back(std::uint32_t((z * mDims[1] + y) * mDims[0] + x));
        }
  }); });
  mCellStart.assign(cellCount + 1, 0);
  for (const auto& cellList : cellsOf)
    for (std::uint32_t cell : cellList) ++mCellStart[cell + 1];
  for (std::size_t k = 0; k < cellCount; ++k) mCellStart[k + 1] += mCellStart[k];
  mTriangles.resize(mCellStart.back());
  std::vector<std::uint32_t> fill(mCellStart.begin(), mCellStart.end() - 1);
  for (std::size_t t = 0; t < n; ++t)  // ascending t within each cell
    for (std::uint32_t cell : cellsOf[t]) mTriangles[fill[cell]++] = std::uint32_t(t);
}

void TriangleBand::refit() {
  const std::size_t n = mA.size();
  mBoxLo.resize(n);
  mBoxHi.resize(n);
  for (std::size_t t = 0; t < n; ++t) {
    mBoxLo[t] = mA[t].cwiseMin(mB[t]).cwiseMin(mC[t]);
    mBoxHi[t] = mA[t].cwiseMax(mB[t]).cwiseMax(mC[t]);
  }
}

long TriangleBand::closest(const Vec3d& p, Vec3d& point) const {
  if (mCellStart.empty()) return -1;
  long cell[3];
  for (int k = 0; k < 3; ++k) {
    const double f = std::floor((p[k] - mOrigin[k]) * mInverseCellSize);
    if (!(f >= 0 && f < double(mDims[k]))) return -1;  // farther than range from every triangle
    cell[k] = long(f);
  }
  const std::size_t index = std::size_t((cell[2] * mDims[1] + cell[1]) * mDims[0] + cell[0]);
  double best = mRange * mRange;
  long bestTriangle = -1;
  for (std::uint32_t s = mCellStart[index]; s < mCellStart[index + 1]; ++s) {
    const std::uint32_t t = mTriangles[s];
    // Lower bound: the distance to the triangle's bounding box.
    const Vec3d outside = (mBoxLo[t] - p).cwiseMax(p - mBoxHi[t]).cwiseMax(0.0);
    if (outside.squaredNorm() >= best) continue;
    const Vec3d q = closestOnTriangle(p, mA[t], mB[t], mC[t]);
    const double d2 = (q - p).squaredNorm();
    if (d2 < best) {
      best = d2;
      bestTriangle = long(t);
      point = q;
    }
  }
  return bestTriangle;
}

} // namespace cascade
