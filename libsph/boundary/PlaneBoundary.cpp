#include "libsph/boundary/PlaneBoundary.h"

#include "libsph/boundary/BoundarySampling.h"

#include <cmath>

namespace cascade {

namespace {
void orthonormalBasis(const Vec3r& normal, Vec3r& u, Vec3r& v) {
  const Vec3r helper = std::abs(normal.x()) < Real(0.9) ? Vec3r::UnitX() : Vec3r::UnitY();
  u = normal.cross(helper).normalized();
  v = normal.cross(u).normalized();
  // keep u x v = normal
  if (u.cross(v).dot(normal) < 0) v = -v;
}
} // namespace

BoundaryPtr PlaneBoundary::infinite(const Vec3r& point, const Vec3r& normal, Real sampleHalfExtent) {
  std::unique_ptr<PlaneBoundary> plane(new PlaneBoundary());
  plane->mCenter = point;
  plane->mNormal = normal.normalized();
  orthonormalBasis(plane->mNormal, plane->mAxisU, plane->mAxisV);
  plane->mHalfU = plane->mHalfV = sampleHalfExtent;
  plane->mFinite = false;
  return plane;
}

BoundaryPtr PlaneBoundary::rectangle(const Vec3r& center, const Vec3r& axisU, const Vec3r& axisV,
                                     Real halfU, Real halfV) {
  std::unique_ptr<PlaneBoundary> plane(new PlaneBoundary());
  plane->mCenter = center;
  plane->mAxisU = axisU.normalized();
  plane->mAxisV = (axisV - axisV.dot(plane->mAxisU) * plane->mAxisU).normalized();
  plane->mNormal = plane->mAxisU.cross(plane->mAxisV);
  plane->mHalfU = halfU;
  plane->mHalfV = halfV;
  plane->mFinite = true;
  return plane;
}

void PlaneBoundary::sampleSurface(Real maxGap, std::vector<Vec3r>& samples) const {
  sampleRectangle(mCenter, mAxisU, mAxisV, mHalfU, mHalfV, maxGap, samples);
}

void PlaneBoundary::sampleSurfaceLattices(Real maxGap, std::vector<SampleLattice>& lattices,
                                          std::vector<Vec3r>&) const {
  lattices.push_back(SampleLattice::rectangle(mCenter, mAxisU, mAxisV, mHalfU, mHalfV, maxGap));
}

void PlaneBoundary::mirrorMaps(const Vec3r& x, Real range, std::uint32_t boundaryIndex,
                               std::vector<MirrorMap>& maps) const {
  const Vec3r rel = x - mCenter;
  const Real distance = rel.dot(mNormal);
  if (distance < 0 || distance >= range) return;  // behind the wall, or too far
  if (mFinite && (std::abs(rel.dot(mAxisU)) > mHalfU || std::abs(rel.dot(mAxisV)) > mHalfV)) return;
  maps.push_back(MirrorMap::reflection(mCenter, mNormal, boundaryIndex));
}

bool PlaneBoundary::isInside(const Vec3r& x) const {
  if (mFinite) return false;  // a finite wall has no volume
  return (x - mCenter).dot(mNormal) < 0;
}

TriangleMesh PlaneBoundary::surfaceMesh() const {
  TriangleMesh mesh;
  const Vec3r corners[4] = {mCenter - mHalfU * mAxisU - mHalfV * mAxisV,
                            mCenter + mHalfU * mAxisU - mHalfV * mAxisV,
                            mCenter + mHalfU * mAxisU + mHalfV * mAxisV,
                            mCenter - mHalfU * mAxisU + mHalfV * mAxisV};
  for (const Vec3r& c : corners) {
    mesh.vertices.push_back(c.cast<float>());
    mesh.normals.push_back(mNormal.cast<float>());
  }
  mesh.triangles.push_back({0, 1, 2});  // counter-clockwise seen from the fluid side
  mesh.triangles.push_back({0, 2, 3});
  mesh.groups.push_back({name(), 0, 2});
  return mesh;
}

void PlaneBoundary::bounds(Vec3r& lo, Vec3r& hi) const {
  lo = hi = mCenter;
  for (int su = -1; su <= 1; su += 2)
    for (int sv = -1; sv <= 1; sv += 2) {
      const Vec3r c = mCenter + Real(su) * mHalfU * mAxisU + Real(sv) * mHalfV * mAxisV;
      lo = lo.cwiseMin(c);
      hi = hi.cwiseMax(c);
    }
}

} // namespace cascade
