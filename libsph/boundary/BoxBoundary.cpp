#include "libsph/boundary/BoxBoundary.h"

#include "libsph/boundary/BoundarySampling.h"

#include <cmath>

namespace cascade {

BoundaryPtr BoxBoundary::tank(const Vec3r& lo, const Vec3r& hi, bool closedTop, unsigned symmetryAxes) {
  std::unique_ptr<BoxBoundary> box(new BoxBoundary());
  box->mCenter = Real(0.5) * (lo + hi);
  box->mHalf = Real(0.5) * (hi - lo);
  box->mTank = true;
  box->mClosedTop = closedTop;
  box->mSymmetryAxes = symmetryAxes & 7u;
  box->makeMirrorMaps();
  return box;
}

BoundaryPtr BoxBoundary::solid(const Vec3r& center, const Vec3r& halfExtents,
                               const Eigen::Matrix<Real, 3, 3>& rotation) {
  std::unique_ptr<BoxBoundary> box(new BoxBoundary());
  box->mCenter = center;
  box->mHalf = halfExtents;
  box->mRotation = rotation;
  box->mTank = false;
  box->makeMirrorMaps();
  return box;
}

void BoxBoundary::makeMirrorMaps() {
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const Vec3r normal = mRotation.col(axis) * (side ? Real(1) : Real(-1));  // outward; reflection is sign-free
      mFaceMap[axis][side] = MirrorMap::reflection(mCenter + normal * mHalf[axis], normal, 0);
      mFaceMap[axis][side].symmetry = mTank && ((mSymmetryAxes >> axis) & 1u);
    }
  if (!mTank) return;
  // Products of the reflections across faces of different axes (edges and corners), in
  // the order mirrorMaps() applies them: the lower axis first.
  const int pairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  for (int p = 0; p < 3; ++p)
    for (int sa = 0; sa < 2; ++sa)
      for (int sb = 0; sb < 2; ++sb)
        mEdgeMap[p][sa][sb] = mFaceMap[pairs[p][1]][sb].after(mFaceMap[pairs[p][0]][sa]);
  for (int s0 = 0; s0 < 2; ++s0)
    for (int s1 = 0; s1 < 2; ++s1)
      for (int s2 = 0; s2 < 2; ++s2)
        mCornerMap[s0][s1][s2] = mFaceMap[2][s2].after(mFaceMap[1][s1]).after(mFaceMap[0][s0]);
}

void BoxBoundary::sampleSurfaceLattices(Real maxGap, std::vector<SampleLattice>& lattices,
                                        std::vector<Vec3r>&) const {
  // Each wall on its own lattice. Two walls sharing an edge use the same count
  // along it, so their edge points coincide: a point on an edge (or corner)
  // belongs to the wall of the lowest axis that holds it, and the later walls
  // drop that row or column of their lattice (no hash pass over the samples).
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      if (!faceIsWall(axis, side)) continue;
      const int a = (axis + 1) % 3, b = (axis + 2) % 3;
      const Vec3r normal = mRotation.col(axis) * (side ? Real(1) : Real(-1));
      SampleLattice wall = SampleLattice::rectangle(mCenter + normal * mHalf[axis], mRotation.col(a), mRotation.col(b),
                                                    mHalf[a], mHalf[b], maxGap);
      if (a < axis && faceIsWall(a, 0)) wall.firstU = 1;
      if (a < axis && faceIsWall(a, 1)) wall.lastU = wall.intervalsU - 1;
      if (b < axis && faceIsWall(b, 0)) wall.firstV = 1;
      if (b < axis && faceIsWall(b, 1)) wall.lastV = wall.intervalsV - 1;
      if (wall.size() > 0) lattices.push_back(wall);
    }
}

void BoxBoundary::sampleSurface(Real maxGap, std::vector<Vec3r>& samples) const {
  std::vector<SampleLattice> lattices;
  sampleSurfaceLattices(maxGap, lattices, samples);
  for (const SampleLattice& lattice : lattices) lattice.append(samples);
}

void BoxBoundary::mirrorMaps(const Vec3r& x, Real range, std::uint32_t boundaryIndex,
                             std::vector<MirrorMap>& maps) const {
  const Vec3r q = mRotation.transpose() * (x - mCenter);
  if (mTank) {
    // Walls within range: one reflection each, and the products of the reflections
    // across walls of different axes (edges and corners), for every such pair within
    // range: in a tank narrower than twice the range (a slab) both walls of an axis
    // are, and the corner where the floor meets the far wall needs its own image.
    unsigned nearSides[3] = {0, 0, 0};  // per axis, bit `side`: that wall within range
    const std::size_t first = maps.size();
    for (int axis = 0; axis < 3; ++axis) {
      if (std::abs(q[axis]) > mHalf[axis] + range) return;  // far outside: not this tank's fluid
      for (int side = 0; side < 2; ++side) {
        if (!faceIsWall(axis, side)) continue;
        const Real sign = side ? Real(1) : Real(-1);
        const Real distance = mHalf[axis] - sign * q[axis];  // > 0 inside
        if (distance < 0 || distance >= range) continue;
        maps.push_back(mFaceMap[axis][side]);
        maps.back().boundary = boundaryIndex;
        nearSides[axis] |= 1u << side;
      }
    }
    if (maps.size() - first < 2) return;
    const auto near = [&](int axis, int side) { return ((nearSides[axis] >> side) & 1u) != 0; };
    const int pairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
    for (int p = 0; p < 3; ++p)
      for (int sa = 0; sa < 2; ++sa)
        for (int sb = 0; sb < 2; ++sb) {
          if (!near(pairs[p][0], sa) || !near(pairs[p][1], sb)) continue;
          maps.push_back(mEdgeMap[p][sa][sb]);
          maps.back().boundary = boundaryIndex;
        }
    for (int s0 = 0; s0 < 2; ++s0)
      for (int s1 = 0; s1 < 2; ++s1)
        for (int s2 = 0; s2 < 2; ++s2) {
          if (!near(0, s0) || !near(1, s1) || !near(2, s2)) continue;
          maps.push_back(mCornerMap[s0][s1][s2]);
          maps.back().boundary = boundaryIndex;
        }
    return;
  }
  // Solid block: closest point on the box; mirror across the tangent plane there
  // (on a face: that face's plane, made once).
  Vec3r excess;
  for (int axis = 0; axis < 3; ++axis) excess[axis] = std::abs(q[axis]) - mHalf[axis];
  if (excess.maxCoeff() <= 0) return;  // inside: penetrated, the repulsion handles it
  int outside = 0, faceAxis = 0;
  for (int axis = 0; axis < 3; ++axis)
    if (excess[axis] > 0) ++outside, faceAxis = axis;
  if (outside == 1) {
    if (excess[faceAxis] >= range) return;
    maps.push_back(mFaceMap[faceAxis][q[faceAxis] > 0 ? 1 : 0]);
    maps.back().boundary = boundaryIndex;
    return;
  }
  Vec3r closest = q;
  for (int axis = 0; axis < 3; ++axis) closest[axis] = std::clamp(q[axis], -mHalf[axis], mHalf[axis]);
  const Vec3r offset = q - closest;
  const Real distance = offset.norm();
  if (distance >= range || distance <= 0) return;
  const Vec3r normal = mRotation * (offset / distance);
  maps.push_back(MirrorMap::reflection(mCenter + mRotation * closest, normal, boundaryIndex));
}

bool BoxBoundary::mayMirrorNear(const Vec3r& x, Real slack, Real range) const {
  if (!mTank) return true;
  // mirrorMaps' walk, for every point within slack of x: a wall's map is added when the
  // point lies within range in front of it, and the walk stops (keeping the maps it
  // added) at the first axis along which the point is far outside.
  const Vec3r q = mRotation.transpose() * (x - mCenter);
  bool any = false;
  for (int axis = 0; axis < 3; ++axis) {
    if (std::abs(q[axis]) > mHalf[axis] + range + slack) return any;
    for (int side = 0; side < 2; ++side) {
      if (!faceIsWall(axis, side)) continue;
      const Real distance = mHalf[axis] - (side ? q[axis] : -q[axis]);
      if (distance > -slack && distance < range + slack) any = true;
    }
  }
  return any;
}

bool BoxBoundary::isInside(const Vec3r& x) const {
  const Vec3r q = mRotation.transpose() * (x - mCenter);
  bool within = true;
  for (int axis = 0; axis < 3; ++axis) {
    if (mTank && axis == 2 && !mClosedTop) {
      if (q[axis] < -mHalf[axis]) within = false;
      continue;
    }
    if (std::abs(q[axis]) > mHalf[axis]) within = false;
  }
  return mTank ? !within : within;
}

bool BoxBoundary::penetrated(const Vec3r& from, const Vec3r& to, Real clearance, Vec3r& exit, Vec3r& normal) const {
  const Vec3r a = mRotation.transpose() * (from - mCenter), b = mRotation.transpose() * (to - mCenter);
  Vec3r local = Vec3r::Zero();
  if (mTank) {
    if (!isInside(to) || isInside(from)) return false;
    Vec3r q = b;
    for (int axis = 0; axis < 3; ++axis) {
      if (q[axis] < -mHalf[axis]) {
        q[axis] = -mHalf[axis] + clearance;
        local[axis] = 1;
      } else if (q[axis] > mHalf[axis] && faceIsWall(axis, 1)) {
        q[axis] = mHalf[axis] - clearance;
        local[axis] = -1;
      }
    }
    exit = mCenter + mRotation * q;
    normal = mRotation * local.normalized();
    return true;
  }
  // Solid block: slab test of the segment a + t (b - a), t in [0, 1].
  const Vec3r d = b - a;
  Real enter = 0, leave = 1;
  int entryAxis = -1;
  for (int axis = 0; axis < 3; ++axis) {
    if (d[axis] == 0) {
      if (std::abs(a[axis]) > mHalf[axis]) return false;
      continue;
    }
    const Real t0 = (-mHalf[axis] - a[axis]) / d[axis], t1 = (mHalf[axis] - a[axis]) / d[axis];
    const Real near = std::min(t0, t1), far = std::max(t0, t1);
    if (near > enter) {
      enter = near;
      entryAxis = axis;
    }
    leave = std::min(leave, far);
    if (enter > leave) return false;
  }
  if (entryAxis < 0) return false;  // started inside: free to leave
  local[entryAxis] = d[entryAxis] > 0 ? Real(-1) : Real(1);
  exit = mCenter + mRotation * (a + enter * d + clearance * local);
  normal = mRotation * local;
  return true;
}

TriangleMesh BoxBoundary::surfaceMesh() const {
  TriangleMesh mesh;
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      if (!faceIsWall(axis, side)) continue;
      const int a = (axis + 1) % 3, b = (axis + 2) % 3;
      const Real sign = side ? Real(1) : Real(-1);
      // Outward normal of the solid; a tank's walls face the fluid (inwards).
      const Vec3r normal = mRotation.col(axis) * (mTank ? -sign : sign);
      const Vec3r center = mCenter + mRotation.col(axis) * (sign * mHalf[axis]);
      Vec3r u = mRotation.col(a) * mHalf[a], v = mRotation.col(b) * mHalf[b];
      if (u.cross(v).dot(normal) < 0) std::swap(u, v);
      const std::uint32_t base = static_cast<std::uint32_t>(mesh.vertices.size());
      const Vec3r corners[4] = {center - u - v, center + u - v, center + u + v, center - u + v};
      for (const Vec3r& c : corners) {
        mesh.vertices.push_back(c.cast<float>());
        mesh.normals.push_back(normal.cast<float>());
      }
      mesh.triangles.push_back({base, base + 1, base + 2});
      mesh.triangles.push_back({base, base + 2, base + 3});
    }
  mesh.groups.push_back({name(), 0, mesh.triangles.size()});
  return mesh;
}

void BoxBoundary::bounds(Vec3r& lo, Vec3r& hi) const {
  const Vec3r extent = mRotation.cwiseAbs() * mHalf;
  lo = mCenter - extent;
  hi = mCenter + extent;
}

} // namespace cascade
