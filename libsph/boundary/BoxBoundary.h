/// @file BoxBoundary.h
/// @brief Box-shaped solids: a tank (fluid inside, walls on its faces, the top
///        open or closed) or a solid block (fluid outside; an inclined slope
///        or a tower), axis aligned or oriented. SEED section 2.2: type I
///        particles on the faces, type II mirrors across the faces near a
///        fluid particle; in a tank's edges and corners also the products of
///        the two or three orthogonal reflections, so the mirrored fluid
///        fills every missing octant.
#pragma once

#include "libsph/boundary/Boundary.h"

namespace cascade {

class BoxBoundary final : public Boundary {
public:
  /// A tank: fluid inside the axis-aligned box [lo, hi]; the top face
  /// (z = hi.z) is a wall only if closedTop. The faces normal to the axes in
  /// the bit mask symmetryAxes (1 = x, 2 = y, 4 = z) are symmetry planes
  /// (MirrorMap::symmetry: a slab standing for a 2-D flow), not walls.
  static BoundaryPtr tank(const Vec3r& lo, const Vec3r& hi, bool closedTop = false, unsigned symmetryAxes = 0);

  /// A solid block: fluid outside; centred at `center`, `halfExtents` along
  /// the columns of `rotation` (an orthonormal matrix).
  static BoundaryPtr solid(const Vec3r& center, const Vec3r& halfExtents,
                           const Eigen::Matrix<Real, 3, 3>& rotation =
                               Eigen::Matrix<Real, 3, 3>::Identity());

  std::string kind() const override { return mTank ? "tank" : "box"; }
  void sampleSurface(Real maxGap, std::vector<Vec3r>& samples) const override;
  void sampleSurfaceLattices(Real maxGap, std::vector<SampleLattice>& lattices,
                             std::vector<Vec3r>& points) const override;
  void mirrorMaps(const Vec3r& x, Real range, std::uint32_t boundaryIndex,
                  std::vector<MirrorMap>& maps) const override;
  /// Tank: outside the box (through a wall); solid: inside the box.
  bool isInside(const Vec3r& x) const override;
  TriangleMesh surfaceMesh() const override;
  /// An open tank's side walls mirror at any height above the rim (its inside test and
  /// the guard treat them as going up without end): not bounded by its faces.
  bool mirrorsNearSurfaceMeshOnly() const override { return !mTank || mClosedTop; }
  /// An open tank: near the slabs its walls mirror in (mirrorMaps' own tests, widened by slack).
  bool mayMirrorNear(const Vec3r& x, Real slack, Real range) const override;
  void bounds(Vec3r& lo, Vec3r& hi) const override;

  /// Exact for both kinds: a solid block is entered where the move first meets it
  /// (slab test: a move through a thin slope counts); a tank where the move leaves
  /// its interior (clamped back a clearance inside each wall it crossed).
  bool penetrated(const Vec3r& from, const Vec3r& to, Real clearance, Vec3r& exit, Vec3r& normal) const override;
  bool isTank() const { return mTank; }
  const Vec3r& center() const { return mCenter; }
  const Vec3r& halfExtents() const { return mHalf; }

private:
  BoxBoundary() = default;
  bool faceIsWall(int axis, int side) const { return !(mTank && !mClosedTop && axis == 2 && side == 1); }
  /// The mirror maps are fixed by the box: made once here (boundary index 0; the
  /// caller's is set on each copy), not per particle and step.
  void makeMirrorMaps();
  MirrorMap mFaceMap[3][2];         ///< reflection across the face of axis, side
  MirrorMap mEdgeMap[3][2][2];      ///< tank: face (a, side a) then face (b, side b), pairs a < b: 01, 02, 12
  MirrorMap mCornerMap[2][2][2];    ///< tank: faces of axes 0, 1, 2 in turn, by their sides
  Vec3r mCenter = Vec3r::Zero(), mHalf = Vec3r::Ones();
  Eigen::Matrix<Real, 3, 3> mRotation = Eigen::Matrix<Real, 3, 3>::Identity();
  bool mTank = false, mClosedTop = false;
  unsigned mSymmetryAxes = 0;  // tank faces that are symmetry planes (bit per axis)
};

} // namespace cascade
