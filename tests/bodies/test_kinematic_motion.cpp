// Prescribed obstacle motion: keyframes (linear translation, slerp rotation)
// and the piston wavemaker; poses, their exact velocities and speed bounds.
#include "libsph/bodies/KinematicMotion.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

using namespace cascade;

namespace {

constexpr double kPi = 3.14159265358979323846;

scene::Keyframe key(double t, scene::Vec3 translate, scene::Vec3 rotate = {0, 0, 0}) {
  scene::Keyframe k;
  k.t = t;
  k.translate = translate;
  k.rotate = rotate;
  return k;
}

scene::Piston makePiston(scene::Vec3 axis, double stroke, double period, double ramp) {
  scene::Piston p;
  p.axis = axis;
  p.stroke = stroke;
  p.period = period;
  p.ramp = ramp;
  return p;
}

void expectNear(const Vec3d& actual, const Vec3d& expected, double tolerance) {
  EXPECT_LE((actual - expected).norm(), tolerance) << "actual " << actual.transpose() << "\nexpected "
                                                   << expected.transpose();
}

/// Each point's velocity from velocityAt matches the central difference of poseAt, 1e-6 relative.
void expectVelocityIsDerivative(const KinematicMotion& motion, double t, const std::vector<Vec3d>& referencePoints) {
  const double h = 1e-6;
  const RigidPose before = motion.poseAt(t - h), after = motion.poseAt(t + h), now = motion.poseAt(t);
  const RigidVelocity velocity = motion.velocityAt(t);
  for (const Vec3d& x : referencePoints) {
    const Vec3d finiteDifference = (after.apply(x) - before.apply(x)) / (2 * h);
    const Vec3d exact = velocity.at(now.apply(x));
    ASSERT_GT(exact.norm(), 1e-3) << "pick points that move at t = " << t;
    EXPECT_LE((finiteDifference - exact).norm(), 1e-6 * exact.norm())
        << "t = " << t << " point " << x.transpose() << "\nfinite difference " << finiteDifference.transpose()
        << "\nexact " << exact.transpose();
  }
}

KinematicMotion tumbling(const Vec3d& origin) {
  return KinematicMotion::fromKeyframes({key(0.0, {0, 0, 0}, {0, 0, 0}),
                                         key(1.0, {1.0, -0.5, 0.3}, {30, -20, 45}),
                                         key(2.5, {0.2, 0.4, 1.0}, {-60, 80, 170})},
                                        origin);
}

} // namespace

TEST(KinematicMotion, KeyframeTranslationIsLinearBetweenKeysAndHoldsOutside) {
  const Vec3d origin(1, 2, 3);
  const KinematicMotion motion =
      KinematicMotion::fromKeyframes({key(1.0, {0, 0, 0}), key(3.0, {2, 4, -2})}, origin);
  const Vec3d p(0.5, -1, 2);

  expectNear(motion.poseAt(1.5).apply(p), p + Vec3d(0.5, 1, -0.5), 1e-12);
  expectNear(motion.poseAt(2.0).apply(p), p + Vec3d(1, 2, -1), 1e-12);
  expectNear(motion.velocityAt(2.0).linear, Vec3d(1, 2, -1), 1e-12);
  expectNear(motion.velocityAt(2.0).angular, Vec3d::Zero(), 1e-12);
  expectNear(motion.velocityAt(2.0).center, origin + Vec3d(1, 2, -1), 1e-12);

  // Before the first key the first holds; after the last the last; velocity zero there.
  EXPECT_TRUE(motion.poseAt(-5.0).isIdentity());
  EXPECT_TRUE(motion.poseAt(0.999).isIdentity());
  EXPECT_TRUE(motion.velocityAt(0.5).isZero());
  expectNear(motion.poseAt(3.0).apply(p), p + Vec3d(2, 4, -2), 1e-12);
  expectNear(motion.poseAt(100.0).apply(p), p + Vec3d(2, 4, -2), 1e-12);
  EXPECT_TRUE(motion.velocityAt(3.0).isZero());
  EXPECT_TRUE(motion.velocityAt(100.0).isZero());
  // At exactly the first key: the segment that starts there (right derivative).
  expectNear(motion.velocityAt(1.0).linear, Vec3d(1, 2, -1), 1e-12);
}

TEST(KinematicMotion, ZeroKeyIsTheIdentityAndASingleKeyIsConstant) {
  const Vec3d origin(0.3, -2, 7);
  const KinematicMotion zero = KinematicMotion::fromKeyframes({key(0.0, {0, 0, 0}, {0, 0, 0})}, origin);
  for (double t : {-1.0, 0.0, 0.5, 10.0}) {
    EXPECT_TRUE(zero.poseAt(t).isIdentity()) << t;
    EXPECT_TRUE(zero.velocityAt(t).isZero()) << t;
  }
  EXPECT_EQ(zero.maxSpeed(-1, 10, 5), 0.0);

  const KinematicMotion single = KinematicMotion::fromKeyframes({key(2.0, {1, 2, 3}, {0, 0, 90})}, origin);
  for (double t : {-1.0, 2.0, 50.0}) {
    // The origin moves by the translation; origin + x goes to origin + translate + Rz(90) x.
    expectNear(single.poseAt(t).apply(origin), origin + Vec3d(1, 2, 3), 1e-12);
    expectNear(single.poseAt(t).apply(origin + Vec3d(1, 0, 0)), origin + Vec3d(1, 2, 3) + Vec3d(0, 1, 0), 1e-12);
    EXPECT_TRUE(single.velocityAt(t).isZero());
  }
}

TEST(KinematicMotion, RotationSlerpsAboutTheOrigin) {
  const Vec3d origin(1, 1, 0.5);
  const KinematicMotion motion =
      KinematicMotion::fromKeyframes({key(0.0, {0, 0, 0}, {0, 0, 0}), key(1.0, {0, 0, 0}, {0, 0, 90})}, origin);

  const RigidPose half = motion.poseAt(0.5);
  const double c = std::cos(kPi / 4), s = std::sin(kPi / 4);
  expectNear(half.apply(origin), origin, 1e-12);  // the origin stays put
  expectNear(half.apply(origin + Vec3d(2, 0, 0)), origin + Vec3d(2 * c, 2 * s, 0), 1e-12);
  expectNear(half.apply(origin + Vec3d(0, 1, 3)), origin + Vec3d(-s, c, 3), 1e-12);

  const RigidVelocity velocity = motion.velocityAt(0.5);
  expectNear(velocity.angular, Vec3d(0, 0, kPi / 2), 1e-12);
  expectNear(velocity.linear, Vec3d::Zero(), 1e-12);
  expectNear(velocity.center, origin, 1e-12);
  // A point at distance 2 from the axis moves at 2 * pi / 2, tangentially.
  expectNear(velocity.at(half.apply(origin + Vec3d(2, 0, 0))), Vec3d(-2 * s, 2 * c, 0) * (kPi / 2), 1e-12);

  // End key holds.
  expectNear(motion.poseAt(1.0).apply(origin + Vec3d(1, 0, 0)), origin + Vec3d(0, 1, 0), 1e-12);
  expectNear(motion.poseAt(7.0).apply(origin + Vec3d(1, 0, 0)), origin + Vec3d(0, 1, 0), 1e-12);
}

TEST(KinematicMotion, SlerpTakesTheShortestPath) {
  // 0 -> 270 degrees about z is -90 degrees the short way.
  const KinematicMotion motion = KinematicMotion::fromKeyframes(
      {key(0.0, {0, 0, 0}, {0, 0, 0}), key(2.0, {0, 0, 0}, {0, 0, 270})}, Vec3d::Zero());
  const double c = std::cos(kPi / 4), s = std::sin(kPi / 4);
  expectNear(motion.poseAt(1.0).apply(Vec3d(1, 0, 0)), Vec3d(c, -s, 0), 1e-12);
  expectNear(motion.velocityAt(1.0).angular, Vec3d(0, 0, -kPi / 4), 1e-12);
}

TEST(KinematicMotion, EulerAnglesAreAboutXThenYThenZ) {
  // R = Rz(90) Ry(0) Rx(90): Rx takes y to z, then Rz takes x to y and leaves z.
  Eigen::Matrix3d rx, rz;
  rx << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  rz << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  const Eigen::Matrix3d expected = rz * rx;
  for (const Vec3d& origin : {Vec3d(0, 0, 0), Vec3d(2, -1, 0.5)}) {
    const KinematicMotion motion = KinematicMotion::fromKeyframes({key(0.0, {0, 0, 0}, {90, 0, 90})}, origin);
    const RigidPose pose = motion.poseAt(0.0);
    EXPECT_LE((pose.rotation - expected).norm(), 1e-12);
    expectNear(pose.apply(origin + Vec3d::UnitX()), origin + Vec3d(0, 1, 0), 1e-12);
    expectNear(pose.apply(origin + Vec3d::UnitY()), origin + Vec3d(0, 0, 1), 1e-12);
    expectNear(pose.apply(origin + Vec3d::UnitZ()), origin + Vec3d(1, 0, 0), 1e-12);
  }
  // Not the other order (Rx Rz would send x to z).
  const KinematicMotion motion = KinematicMotion::fromKeyframes({key(0.0, {0, 0, 0}, {90, 0, 90})}, Vec3d::Zero());
  EXPECT_GT((motion.poseAt(0).rotation - rx * rz).norm(), 0.5);
}

TEST(KinematicMotion, KeyframeVelocityIsTheDerivativeOfThePose) {
  const Vec3d origin(0.3, -0.2, 0.5);
  const KinematicMotion motion = tumbling(origin);
  const std::vector<Vec3d> points = {origin + Vec3d(1, 0, 0), origin + Vec3d(0.2, -0.7, 0.4),
                                     Vec3d(-1.5, 2.0, 0.3), Vec3d(4, 4, -3)};
  for (double t : {0.13, 0.5, 0.77, 1.3, 1.9, 2.4})
    expectVelocityIsDerivative(motion, t, points);
  // At a key time the velocity is the right derivative: the next segment's.
  const double h = 1e-7;
  const Vec3d x = origin + Vec3d(0.2, -0.7, 0.4);
  const Vec3d forward = (motion.poseAt(1.0 + h).apply(x) - motion.poseAt(1.0).apply(x)) / h;
  const Vec3d exact = motion.velocityAt(1.0).at(motion.poseAt(1.0).apply(x));
  EXPECT_LE((forward - exact).norm(), 1e-5 * exact.norm());
  const Vec3d left = motion.velocityAt(1.0 - 1e-9).at(motion.poseAt(1.0).apply(x));
  EXPECT_GT((left - exact).norm(), 1e-2 * exact.norm());  // the kink is real: right is not left
}

TEST(KinematicMotion, PistonVelocityIsTheDerivativeBeforeAndAfterTheRamp) {
  const Vec3d origin(0.5, 0, 0.2);
  const KinematicMotion motion = KinematicMotion::piston(makePiston({1, 2, 0}, 0.2, 1.5, 2.0), origin);
  const std::vector<Vec3d> points = {origin, Vec3d(3, -1, 2)};
  for (double t : {0.3, 1.1, 1.9, 2.3, 3.7, 10.05})
    expectVelocityIsDerivative(motion, t, points);
  for (double t : {-1.0, 0.7, 5.0}) {
    EXPECT_TRUE(motion.poseAt(t).rotation == Mat3d::Identity());
    EXPECT_EQ(motion.velocityAt(t).angular, Vec3d::Zero());
  }
}

TEST(KinematicMotion, PistonAmplitudeRampAndContinuity) {
  const double stroke = 0.3, period = 2.0, ramp = 1.25;
  const Vec3d origin(1, 1, 1);
  const Vec3d axis = Vec3d(0, 0, 2).normalized();
  const KinematicMotion motion = KinematicMotion::piston(makePiston({0, 0, 2}, stroke, period, ramp), origin);

  // Zero at t = 0 and before; full amplitude S / 2 along the unit axis at T/4 + k T after the ramp.
  expectNear(motion.poseAt(0.0).apply(origin), origin, 1e-15);
  expectNear(motion.poseAt(-3.0).apply(origin), origin, 1e-15);
  EXPECT_TRUE(motion.velocityAt(-3.0).isZero());
  EXPECT_TRUE(motion.velocityAt(0.0).isZero());  // ramped: starts at rest
  for (int k : {1, 2, 5}) {
    const double t = period / 4 + k * period;
    expectNear(motion.poseAt(t).apply(origin), origin + axis * (stroke / 2), 1e-12);
    expectNear(motion.poseAt(t).apply(Vec3d(7, -2, 3)), Vec3d(7, -2, 3) + axis * (stroke / 2), 1e-12);
    expectNear(motion.velocityAt(t).linear, Vec3d::Zero(), 1e-12);  // turning point
    expectNear(motion.poseAt(t + period / 2).apply(origin), origin - axis * (stroke / 2), 1e-12);
  }
  // Within the ramp the amplitude is smaller.
  EXPECT_LT((motion.poseAt(period / 4).apply(origin) - origin).norm(), 0.99 * stroke / 2);

  // Velocity continuous across the ramp end, and at t = 0.
  const double eps = 1e-9;
  const Vec3d before = motion.velocityAt(ramp - eps).linear, after = motion.velocityAt(ramp + eps).linear;
  const Vec3d at = motion.velocityAt(ramp).linear;
  EXPECT_GT(at.norm(), 0.1);  // 5/8 of a period: moving, and sin != 0 so the ramp slope would show
  EXPECT_LE((before - after).norm(), 1e-6 * at.norm());
  EXPECT_LE((before - at).norm(), 1e-6 * at.norm());
  EXPECT_LE(motion.velocityAt(eps).linear.norm(), 1e-6);

  // Without a ramp: full amplitude at T/4, moving at once.
  const KinematicMotion sharp = KinematicMotion::piston(makePiston({1, 0, 0}, stroke, period, 0.0), origin);
  expectNear(sharp.poseAt(period / 4).apply(origin), origin + Vec3d(stroke / 2, 0, 0), 1e-12);
  expectNear(sharp.velocityAt(0.0).linear, Vec3d(stroke / 2 * 2 * kPi / period, 0, 0), 1e-12);
  EXPECT_TRUE(sharp.poseAt(0.0).isIdentity());
}

TEST(KinematicMotion, MaxSpeedBoundsTheSampledSpeeds) {
  const Vec3d origin(0.3, -0.2, 0.5);
  const double radius = 0.8;
  std::vector<Vec3d> offsets;  // reference points within `radius` of the origin
  for (int i = 0; i < 26; ++i) {
    const Vec3d direction(double(i % 3) - 1, double((i / 3) % 3) - 1, double(i / 9) - 1);
    if (direction.norm() > 0) offsets.push_back(direction.normalized() * radius);
  }
  offsets.push_back(Vec3d::Zero());

  auto sampledMax = [&](const KinematicMotion& motion, double t0, double t1) {
    double best = 0;
    for (int i = 0; i <= 400; ++i) {
      const double t = t0 + (t1 - t0) * i / 400.0;
      const RigidPose pose = motion.poseAt(t);
      const RigidVelocity velocity = motion.velocityAt(t);
      for (const Vec3d& offset : offsets)
        best = std::max(best, velocity.at(pose.apply(origin + offset)).norm());
    }
    return best;
  };

  const KinematicMotion keys = tumbling(origin);
  for (auto [t0, t1] : {std::pair{-1.0, 4.0}, std::pair{0.2, 0.9}, std::pair{1.1, 2.4}, std::pair{0.9, 1.1}}) {
    const double sampled = sampledMax(keys, t0, t1);
    EXPECT_GT(sampled, 0.1);
    EXPECT_GE(keys.maxSpeed(t0, t1, radius), sampled * (1 - 1e-12)) << t0 << " " << t1;
    EXPECT_GE(keys.maxSpeed(t1, t0, radius), sampled * (1 - 1e-12));  // order does not matter
  }
  EXPECT_EQ(keys.maxSpeed(3.0, 9.0, radius), 0.0);  // after the last key nothing moves
  EXPECT_EQ(keys.maxSpeed(-9.0, -1.0, radius), 0.0);

  const KinematicMotion piston = KinematicMotion::piston(makePiston({1, 2, 0}, 0.2, 1.5, 2.0), origin);
  for (auto [t0, t1] : {std::pair{-1.0, 6.0}, std::pair{0.0, 1.9}, std::pair{2.1, 5.0}, std::pair{1.0, 2.5}}) {
    const double sampled = sampledMax(piston, t0, t1);
    EXPECT_GT(sampled, 0.01);
    EXPECT_GE(piston.maxSpeed(t0, t1, radius), sampled * (1 - 1e-12)) << t0 << " " << t1;
  }
  // After the ramp the bound is the exact peak speed (S / 2) (2 pi / T).
  EXPECT_NEAR(piston.maxSpeed(2.0, 5.0, radius), 0.1 * 2 * kPi / 1.5, 1e-12);
  EXPECT_EQ(piston.maxSpeed(-3.0, -1.0, radius), 0.0);
}
