/// @file PlaneBoundary.h
/// @brief A wall that is a plane: infinite, or a finite rectangle (an
///        inclined slope). Fluid lives on the side the normal points to.
///        SEED section 2.2 (type I samples on the plane, type II mirrors
///        across it).
#pragma once

#include "libsph/boundary/Boundary.h"

namespace cascade {

class PlaneBoundary final : public Boundary {
public:
  /// Infinite plane through `point` with `normal` (towards the fluid).
  /// sampleSurface() then covers the square of half size `sampleHalfExtent`
  /// around `point` (type I particles need a finite set).
  static BoundaryPtr infinite(const Vec3r& point, const Vec3r& normal, Real sampleHalfExtent);

  /// Finite rectangle centred at `center` with unit axes `axisU`, `axisV`
  /// (normal = axisU x axisV, towards the fluid) and half sizes.
  static BoundaryPtr rectangle(const Vec3r& center, const Vec3r& axisU, const Vec3r& axisV,
                               Real halfU, Real halfV);

  std::string kind() const override { return "plane"; }
  void sampleSurface(Real maxGap, std::vector<Vec3r>& samples) const override;
  void sampleSurfaceLattices(Real maxGap, std::vector<SampleLattice>& lattices,
                             std::vector<Vec3r>& points) const override;
  void mirrorMaps(const Vec3r& x, Real range, std::uint32_t boundaryIndex,
                  std::vector<MirrorMap>& maps) const override;
  /// Behind the plane (within the rectangle for a finite one, up to one range deep).
  bool isInside(const Vec3r& x) const override;
  TriangleMesh surfaceMesh() const override;
  bool mirrorsNearSurfaceMeshOnly() const override { return mFinite; }
  void bounds(Vec3r& lo, Vec3r& hi) const override;

  const Vec3r& normal() const { return mNormal; }
  const Vec3r& center() const { return mCenter; }

private:
  PlaneBoundary() = default;
  Vec3r mCenter = Vec3r::Zero(), mNormal = Vec3r::UnitZ();
  Vec3r mAxisU = Vec3r::UnitX(), mAxisV = Vec3r::UnitY();
  Real mHalfU = 0, mHalfV = 0;
  bool mFinite = true;
};

} // namespace cascade
