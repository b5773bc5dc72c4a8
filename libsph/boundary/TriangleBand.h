/// @file TriangleBand.h
/// @brief Closest-point queries of one fixed range against a triangle mesh:
///        the type II mirror query of SEED section 2.2 (range kappa h), asked
///        for every fluid particle near an obstacle in every step.
///
/// A grid of cells of edge range / 2 covers the mesh's bounds grown by the
/// range; each cell lists the triangles that can hold the closest surface
/// point of any point of the cell within the range: those whose distance to
/// the cell centre is at most range + half the cell diagonal (triangle
/// inequality), plus a slack by which the corners may move afterwards (a
/// deforming mesh between two frames). A query reads one cell and tests its triangles in index
/// order, skipping those whose bounding box is already farther than the best
/// hit, so ties go to the lowest index, as in a scan over all triangles.
/// Closest point on a triangle: Ericson, Real-Time Collision Detection 5.1.5.
#pragma once

#include "libsph/Types.h"

#include <cstdint>
#include <vector>

namespace cascade {

/// Closest point on triangle (a, b, c) to p (Ericson 2005, section 5.1.5).
Vec3d closestOnTriangle(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c);

class TriangleBand {
public:
  /// Indexes triangles (a[t], b[t], c[t]) for queries of `range`; the corner
  /// arrays must outlive the band. With `slack` > 0 the cells list the triangles
  /// within range + slack, so the corners may move by up to `slack` (then refit()).
  TriangleBand(const std::vector<Vec3d>& a, const std::vector<Vec3d>& b, const std::vector<Vec3d>& c,
               double range, double slack = 0);

  /// After the corners moved (each at most `slack` from where the band was built):
  /// the triangles' bounds from the corners now.
  void refit();

  double range() const { return mRange; }

  /// The closest surface point strictly closer than range(): its triangle
  /// index (and `point`), or -1 if none.
  long closest(const Vec3d& p, Vec3d& point) const;

  /// Triangle entries over all cells (the index's size).
  std::size_t entryCount() const { return mTriangles.size(); }

private:
  const std::vector<Vec3d>& mA;
  const std::vector<Vec3d>& mB;
  const std::vector<Vec3d>& mC;
  std::vector<Vec3d> mBoxLo, mBoxHi;  // per-triangle bounds
  double mRange = 0, mCellSize = 1, mInverseCellSize = 1;
  Vec3d mOrigin = Vec3d::Zero();
  long mDims[3] = {0, 0, 0};
  std::vector<std::uint32_t> mCellStart, mTriangles;
};

} // namespace cascade
