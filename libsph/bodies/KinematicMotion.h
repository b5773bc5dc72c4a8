/// @file KinematicMotion.h
/// @brief A prescribed (kinematic) rigid motion of an obstacle, the scene's
///        "motion" (scene::Motion): keyframes or a piston wavemaker. The
///        reference geometry is the obstacle as the scene placed it; at time t
///        it maps to world by x = origin + d(t) + R(t) (x_ref - origin), where
///        `origin` is the placed mesh's own origin (world).
///
/// Keyframes: d is linear in time between keys, R the shortest-path slerp
/// between the keys' rotations ("rotate" in degrees about x, then y, then z:
/// R = Rz Ry Rx, as Transform::rotationFromEulerDegrees). Before the first key
/// the first key holds, after the last the last one (velocity zero there). The
/// slerp takes the shortest path, so two keys 360 degrees apart do not turn.
///
/// Piston: d(t) = axis (stroke / 2) sin(2 pi t / period) ramp(t), R = I, with
/// ramp(t) = 0 for t < 0, (1 - cos(pi t / ramp)) / 2 on [0, ramp), 1 after
/// (ramp = 0: no ramp). The half cosine has zero slope at both ends, so the
/// paddle's velocity has no jump where the ramp ends (nor where it starts):
/// an impulsive change of wall velocity would put a pressure spike on the
/// paddle and shake the water in front of it.
///
/// velocityAt is the exact time derivative of poseAt. Where that is not
/// differentiable (at a key time, and at t = 0 of a piston without a ramp)
/// it is the right derivative: at exactly a key time the segment that starts
/// there gives the velocity (at the last key: zero).
#pragma once

#include "libsph/Types.h"
#include "libsph/bodies/RigidPose.h"
#include "libsph/scene/Scene.h"

#include <Eigen/Geometry>

#include <vector>

namespace cascade {

/// A prescribed rigid motion of an obstacle about its origin `origin` (the placed mesh's own origin, world):
/// at time t the reference (placed) geometry maps to world by x = origin + d(t) + R(t) (x_ref - origin).
class KinematicMotion {
public:
  /// Keys sorted by t (equal times allowed: the later key wins from that time on), validated by the caller.
  /// No keys: the identity pose at all times; a single key: that constant pose.
  static KinematicMotion fromKeyframes(std::vector<scene::Keyframe> keys, const Vec3d& origin);
  /// The axis is normalised here (a zero axis, stroke or a period <= 0: no motion).
  static KinematicMotion piston(const scene::Piston& piston, const Vec3d& origin);

  RigidPose poseAt(double t) const;
  /// Exact time derivative of poseAt (right derivative at key times), center = origin + d(t).
  RigidVelocity velocityAt(double t) const;
  /// The largest speed any point within `radius` of the origin reaches over [t0, t1] (for time-step limits),
  /// an upper bound: max |d'| + |omega| radius. Points are taken within `radius` of the origin in the
  /// reference geometry, i.e. within `radius` of the moving center origin + d(t).
  double maxSpeed(double t0, double t1, double radius) const;

private:
  enum class Kind { Keyframes, Piston };

  struct Key {
    double t = 0;
    Vec3d translation = Vec3d::Zero();
    Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  };

  /// One keyframe segment [keys[k], keys[k + 1]]: constant linear and angular rate.
  struct Segment {
    Vec3d linear = Vec3d::Zero();       ///< (d1 - d0) / (t1 - t0)
    Vec3d axis = Vec3d::UnitZ();        ///< unit axis of q0^-1 q1, in key 0's body frame
    double angle = 0;                   ///< rad, in [0, pi]
    Vec3d angularWorld = Vec3d::Zero(); ///< R0 axis angle / (t1 - t0), constant along the segment
  };

  struct State {
    Vec3d displacement = Vec3d::Zero();
    Mat3d rotation = Mat3d::Identity();
    Vec3d linear = Vec3d::Zero();
    Vec3d angular = Vec3d::Zero();
  };

  State stateAt(double t) const;
  /// Index k of the segment [keys[k], keys[k + 1]] in use at t, or -1 when a key holds.
  int segmentAt(double t) const;

  Kind mKind = Kind::Keyframes;
  Vec3d mOrigin = Vec3d::Zero();

  std::vector<Key> mKeys;
  std::vector<Segment> mSegments;  ///< mKeys.size() - 1 entries

  Vec3d mAxis = Vec3d::Zero();  ///< unit piston axis
  double mAmplitude = 0;        ///< stroke / 2
  double mOmega = 0;            ///< 2 pi / period
  double mRamp = 0;             ///< ramp duration, s
};

} // namespace cascade
