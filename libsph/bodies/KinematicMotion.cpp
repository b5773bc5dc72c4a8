#include "libsph/bodies/KinematicMotion.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace cascade {

namespace {

constexpr double kPi = 3.14159265358979323846;

Vec3d toVec3d(const scene::Vec3& v) { return Vec3d(v[0], v[1], v[2]); }

/// Rotation from Euler angles in degrees, applied about x, then y, then z
/// (R = Rz Ry Rx), exactly as Transform::rotationFromEulerDegrees, in double.
Eigen::Quaterniond quaternionFromEulerDegrees(const Vec3d& degrees) {
  const double toRadians = kPi / 180.0;
  Eigen::Quaterniond q = Eigen::AngleAxisd(degrees.z() * toRadians, Vec3d::UnitZ()) *
                         Eigen::AngleAxisd(degrees.y() * toRadians, Vec3d::UnitY()) *
                         Eigen::AngleAxisd(degrees.x() * toRadians, Vec3d::UnitX());
  q.normalize();
  return q;
}

} // namespace

KinematicMotion KinematicMotion::fromKeyframes(std::vector<scene::Keyframe> keys, const Vec3d& origin) {
  KinematicMotion motion;
  motion.mKind = Kind::Keyframes;
  motion.mOrigin = origin;
  motion.mKeys.reserve(keys.size());
  for (const scene::Keyframe& key : keys) {
    Key k;
    k.t = key.t;
    k.translation = toVec3d(key.translate);
    k.rotation = quaternionFromEulerDegrees(toVec3d(key.rotate));
    motion.mKeys.push_back(k);
  }
  for (std::size_t k = 0; k + 1 < motion.mKeys.size(); ++k) {
    const Key& a = motion.mKeys[k];
    const Key& b = motion.mKeys[k + 1];
    Segment segment;
    const double dt = b.t - a.t;
    if (dt > 0) {
      // Shortest path: q and -q are the same rotation; pick the one nearer q0.
      Eigen::Quaterniond q1 = b.rotation;
      if (a.rotation.dot(q1) < 0) q1.coeffs() = -q1.coeffs();
      Eigen::Quaterniond relative = a.rotation.conjugate() * q1;  // w = q0 . q1 >= 0
      relative.normalize();
      const double sinHalf = relative.vec().norm();
      if (sinHalf > 0) {
        segment.axis = relative.vec() / sinHalf;
        segment.angle = 2.0 * std::atan2(sinHalf, relative.w());  // in [0, pi]
      }
      segment.linear = (b.translation - a.translation) / dt;
      // R(t) = R0 Rrel(s): the body rate axis angle / dt is R0 axis angle / dt in world axes
      // (axis is invariant under Rrel(s), a rotation about itself).
      segment.angularWorld = (a.rotation * segment.axis) * (segment.angle / dt);
    }
    motion.mSegments.push_back(segment);
  }
  return motion;
}

KinematicMotion KinematicMotion::piston(const scene::Piston& piston, const Vec3d& origin) {
  KinematicMotion motion;
  motion.mKind = Kind::Piston;
  motion.mOrigin = origin;
  const Vec3d axis = toVec3d(piston.axis);
  const double length = axis.norm();
  if (length > 0 && piston.period > 0 && std::isfinite(piston.period)) {
    motion.mAxis = axis / length;
    motion.mAmplitude = 0.5 * piston.stroke;
    motion.mOmega = 2.0 * kPi / piston.period;
  }
  motion.mRamp = std::max(piston.ramp, 0.0);
  return motion;
}

int KinematicMotion::segmentAt(double t) const {
  if (mKeys.size() < 2) return -1;
  if (!(t >= mKeys.front().t) || t >= mKeys.back().t) return -1;
  // The last key with key.t <= t (right derivative at a key time); its successor is strictly later.
  const auto after = std::upper_bound(mKeys.begin(), mKeys.end(), t,
                                      [](double time, const Key& key) { return time < key.t; });
  return int(after - mKeys.begin()) - 1;
}

KinematicMotion::State KinematicMotion::stateAt(double t) const {
  State state;
  if (mKind == Kind::Piston) {
    if (!(t >= 0) || mAmplitude == 0 || mOmega == 0) return state;
    double ramp = 1, rampRate = 0;
    if (mRamp > 0 && t < mRamp) {
      const double phase = kPi * t / mRamp;
      ramp = 0.5 * (1.0 - std::cos(phase));
      rampRate = 0.5 * (kPi / mRamp) * std::sin(phase);
    }
    const double sine = std::sin(mOmega * t), cosine = std::cos(mOmega * t);
    state.displacement = mAxis * (mAmplitude * sine * ramp);
    state.linear = mAxis * (mAmplitude * (mOmega * cosine * ramp + sine * rampRate));
    return state;
  }

  if (mKeys.empty()) return state;
  const int k = segmentAt(t);
  if (k < 0) {  // a key holds: the first before it, the last from it on
    const Key& key = !(t >= mKeys.front().t) ? mKeys.front() : mKeys.back();
    state.displacement = key.translation;
    state.rotation = key.rotation.toRotationMatrix();
    return state;
  }
  const Key& a = mKeys[std::size_t(k)];
  const Key& b = mKeys[std::size_t(k) + 1];
  const Segment& segment = mSegments[std::size_t(k)];
  const double s = (t - a.t) / (b.t - a.t);
  state.displacement = a.translation + s * (b.translation - a.translation);
  state.rotation = a.rotation.toRotationMatrix() * Eigen::AngleAxisd(s * segment.angle, segment.axis).toRotationMatrix();
  state.linear = segment.linear;
  state.angular = segment.angularWorld;
  return state;
}

RigidPose KinematicMotion::poseAt(double t) const {
  const State state = stateAt(t);
  RigidPose pose;
  pose.rotation = state.rotation;
  pose.translation = mOrigin + state.displacement - state.rotation * mOrigin;
  return pose;
}

RigidVelocity KinematicMotion::velocityAt(double t) const {
  const State state = stateAt(t);
  RigidVelocity velocity;
  velocity.linear = state.linear;
  velocity.angular = state.angular;
  velocity.center = mOrigin + state.displacement;
  return velocity;
}

double KinematicMotion::maxSpeed(double t0, double t1, double radius) const {
  if (t0 > t1) std::swap(t0, t1);
  radius = std::max(radius, 0.0);
  if (mKind == Kind::Piston) {
    if (mAmplitude == 0 || mOmega == 0 || t1 < 0) return 0;
    if (mRamp <= 0 || t0 >= mRamp) return std::abs(mAmplitude) * mOmega;
    // |omega cos ramp + sin ramp'| <= sqrt((omega ramp)^2 + ramp'^2), ramp <= 1, ramp' <= pi / (2 ramp)
    const double rampRate = 0.5 * kPi / mRamp;
    return std::abs(mAmplitude) * std::sqrt(mOmega * mOmega + rampRate * rampRate);
  }
  double best = 0;
  for (std::size_t k = 0; k < mSegments.size(); ++k) {
    const double a = mKeys[k].t, b = mKeys[k + 1].t;
    if (!(b > a) || a > t1 || b < t0) continue;  // closed intervals: conservative at the ends
    const Segment& segment = mSegments[k];
    best = std::max(best, segment.linear.norm() + segment.angularWorld.norm() * radius);
  }
  return best;
}

} // namespace cascade
