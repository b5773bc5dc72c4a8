#include "libsph/boundary/Boundary.h"

#include <Eigen/Geometry>

#include <cmath>

namespace cascade {

MirrorMap MirrorMap::reflection(const Vec3r& point, const Vec3r& normal, std::uint32_t boundary) {
  // x' = x - 2 ((x - p) . n) n = (I - 2 n n^T) x + 2 (p . n) n
  MirrorMap map;
  map.linear = Eigen::Matrix<Real, 3, 3>::Identity() - Real(2) * normal * normal.transpose();
  map.offset = Real(2) * point.dot(normal) * normal;
  map.boundary = boundary;
  return map;
}

MirrorMap MirrorMap::after(const MirrorMap& first) const {
  MirrorMap map;
  map.linear = linear * first.linear;
  map.offset = linear * first.offset + offset;
  map.boundary = boundary;
  map.symmetry = symmetry && first.symmetry;
  map.wallVelocity = wallVelocity.isZero() ? first.wallVelocity : wallVelocity;
  return map;
}

Eigen::Matrix<Real, 3, 3> Transform::rotationFromEulerDegrees(const Vec3r& degrees) {
  const double toRadians = 3.14159265358979323846 / 180.0;
  const Eigen::Matrix3d r =
      (Eigen::AngleAxisd(double(degrees.z()) * toRadians, Eigen::Vector3d::UnitZ()) *
       Eigen::AngleAxisd(double(degrees.y()) * toRadians, Eigen::Vector3d::UnitY()) *
       Eigen::AngleAxisd(double(degrees.x()) * toRadians, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  return r.cast<Real>();
}

} // namespace cascade
