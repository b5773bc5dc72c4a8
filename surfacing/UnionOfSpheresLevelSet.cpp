// Union of spheres: OpenVDB tools::ParticlesToLevelSet (LevelSetMethods.h).
#include "surfacing/LevelSetMethods.h"
#include "surfacing/detail/BandVelocity.h"

#include <openvdb/tools/ParticlesToLevelSet.h>

namespace cascade::surfacing {

namespace {
/// OpenVDB's particle-list concept over Cascade positions, one radius for all.
struct SphereList {
  using PosType = openvdb::Vec3R;
  const std::vector<Vec3r>& positions;
  double radius;
  std::size_t size() const { return positions.size(); }
  void getPos(std::size_t i, openvdb::Vec3R& pos) const {
    pos = openvdb::Vec3R(positions[i].x(), positions[i].y(), positions[i].z());
  }
  void getPosRad(std::size_t i, openvdb::Vec3R& pos, openvdb::Real& rad) const {
    getPos(i, pos);
    rad = radius;
  }
};
} // namespace

ParticleLevelSet unionOfSpheresLevelSet(const std::vector<Vec3r>& positions, const LevelSetSettings& settings) {
  auto grid = openvdb::createLevelSet<openvdb::FloatGrid>(settings.voxelSize, settings.halfWidth);
  const double radius = settings.radius > 0 ? settings.radius : 1.0 * settings.spacing;
  openvdb::tools::ParticlesToLevelSet<openvdb::FloatGrid> raster(*grid);
  raster.setRmin(0.5);  // voxel units: keep every particle the user asked for
  raster.rasterizeSpheres(SphereList{positions, radius});
  raster.finalize(true);
  ParticleLevelSet result{grid, nullptr};
  if (settings.velocities)
    result.velocity = detail::isotropicKernelVelocities(positions, *settings.velocities, 2 * settings.spacing,
                                                        settings.voxelSize, {});
  return result;
}

} // namespace cascade::surfacing
