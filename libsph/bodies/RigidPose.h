/// @file RigidPose.h
/// @brief Where a rigid solid is and how it moves at one instant: the pose maps
///        the solid's reference coordinates (where the scene placed it, at
///        rest) to world coordinates, x = R x_ref + t, and the velocity field
///        is v(x) = linear + angular x (x - center). Double precision: a body's
///        state is integrated over tens of thousands of steps.
#pragma once

#include "libsph/Types.h"

#include <Eigen/Geometry>

namespace cascade {

using Mat3d = Eigen::Matrix3d;

struct RigidPose {
  Mat3d rotation = Mat3d::Identity();
  Vec3d translation = Vec3d::Zero();

  Vec3d apply(const Vec3d& reference) const { return rotation * reference + translation; }
  Vec3d applyInverse(const Vec3d& world) const { return rotation.transpose() * (world - translation); }
  bool isIdentity() const { return translation == Vec3d::Zero() && rotation == Mat3d::Identity(); }
};

struct RigidVelocity {
  Vec3d linear = Vec3d::Zero();   ///< velocity of the point `center`, m/s
  Vec3d angular = Vec3d::Zero();  ///< rad/s, world axes
  Vec3d center = Vec3d::Zero();   ///< world point that moves with `linear`

  Vec3d at(const Vec3d& world) const { return linear + angular.cross(world - center); }
  bool isZero() const { return linear == Vec3d::Zero() && angular == Vec3d::Zero(); }
};

} // namespace cascade
