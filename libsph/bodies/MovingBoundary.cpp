#include "libsph/bodies/MovingBoundary.h"

#include "libsph/Errors.h"
#include "libsph/io/BinaryPod.h"

#include <algorithm>
#include <cmath>
#include <istream>
#include <ostream>

namespace cascade {

namespace {
Vec3r toWorld(const RigidPose& pose, const Vec3r& reference) {
  return pose.apply(reference.cast<double>()).cast<Real>();
}
Vec3r toReference(const RigidPose& pose, const Vec3r& world) {
  return pose.applyInverse(world.cast<double>()).cast<Real>();
}

std::vector<Vec3d> hullOf(const Boundary& reference) {
  const TriangleMesh mesh = reference.surfaceMesh();
  std::vector<Vec3d> hull;
  hull.reserve(mesh.vertices.size());
  for (const Eigen::Vector3f& v : mesh.vertices) hull.push_back(v.cast<double>());
  return hull;
}

} // namespace

MovingBoundary::MovingBoundary(BoundaryPtr reference, KinematicMotion motion)
    : mReference(std::move(reference)), mMotion(std::move(motion)), mHull(hullOf(*mReference)) {
  setName(mReference->name());
  moveTo(0.0);
  mPreviousPose = mPose;
  for (const Vec3d& p : mHull) mRadius = std::max(mRadius, (mPose.apply(p) - mVelocity.center).norm());
}

MovingBoundary::MovingBoundary(BoundaryPtr reference, RigidBody body)
    : mReference(std::move(reference)), mBody(std::move(body)), mHull(hullOf(*mReference)) {
  setName(mReference->name());
  setPose(mBody->pose(), mBody->velocity());
  mPreviousPose = mPose;
  for (const Vec3d& p : mHull) mRadius = std::max(mRadius, (mPose.apply(p) - mVelocity.center).norm());
}

void MovingBoundary::setPose(const RigidPose& pose, const RigidVelocity& velocity) {
  mPreviousPose = mPose;
  mPose = pose;
  mVelocity = velocity;
}

void MovingBoundary::moveTo(double t) {
  if (mMotion) setPose(mMotion->poseAt(t), mMotion->velocityAt(t));
}

double MovingBoundary::maxSurfaceSpeed() const {
  return mVelocity.linear.norm() + mVelocity.angular.norm() * mRadius;
}

void MovingBoundary::applyImpulse(const Vec3d& impulse, const Vec3d& angular) {
  if (!mBody) return;
  mBody->applyImpulse(impulse, angular);
  mVelocity = mBody->velocity();
}

double MovingBoundary::maxMotionSpeed() const {
  return mMotion ? mMotion->maxSpeed(0.0, 1e30, mRadius) : 0.0;
}

void MovingBoundary::advance(double t, double dt, const Vec3d& fluidForce, const Vec3d& fluidTorque,
                             const Vec3d& gravity, const std::vector<const Boundary*>& solids, Real clearance) {
  if (mMotion) {
    moveTo(t);
    return;
  }
  RigidBody& body = *mBody;
  const RigidPose before = mPose;
  body.integrate(fluidForce + body.mass() * gravity, fluidTorque, dt);
  const RigidPose after = body.pose();
  std::vector<RigidContact> contacts;
  for (const Vec3d& p : mHull) {
    const Vec3r from = before.apply(p).cast<Real>(), to = after.apply(p).cast<Real>();
    // The move is tested a clearance further (a speculative contact: a vertex resting a
    // clearance off the floor touches it, so a body at rest on it stays at rest).
    const Vec3r move = to - from;
    const Real length = move.norm();
    const Vec3r reach = length > 0 ? Vec3r(to + (clearance / length) * move) : to;
    for (const Boundary* solid : solids) {
      Vec3r exit, normal;
      if (!solid->penetrated(from, reach, clearance, exit, normal)) continue;
      const double depth = double((exit - to).dot(normal));  // < 0: not yet in, still approaching
      contacts.push_back(RigidContact{to.cast<double>(), normal.cast<double>().normalized(), depth});
    }
  }
  body.resolveContacts(contacts);
  mPreviousPose = before;
  mPose = body.pose();
  mVelocity = body.velocity();
}

void MovingBoundary::sampleSurface(Real maxGap, std::vector<Vec3r>& samples) const {
  const std::size_t first = samples.size();
  mReference->sampleSurface(maxGap, samples);
  for (std::size_t k = first; k < samples.size(); ++k) samples[k] = toWorld(mPose, samples[k]);
}

void MovingBoundary::mirrorMaps(const Vec3r& x, Real range, std::uint32_t boundaryIndex,
                                std::vector<MirrorMap>& maps) const {
  const std::size_t first = maps.size();
  mReference->mirrorMaps(toReference(mPose, x), range, boundaryIndex, maps);
  if (maps.size() == first) return;
  // M = P M_ref P^-1: linear R L R^T, offset R o + t - R L R^T t.
  const Eigen::Matrix<Real, 3, 3> r = mPose.rotation.cast<Real>();
  const Vec3r t = mPose.translation.cast<Real>();
  for (std::size_t k = first; k < maps.size(); ++k) {
    MirrorMap& map = maps[k];
    const Eigen::Matrix<Real, 3, 3> linear = r * map.linear * r.transpose();
    map.offset = r * map.offset + t - linear * t;
    map.linear = linear;
    const Vec3r wall = Real(0.5) * (x + map.apply(x));  // on the mirror plane
    map.wallVelocity = velocityAt(wall);
  }
}

bool MovingBoundary::isInside(const Vec3r& x) const { return mReference->isInside(toReference(mPose, x)); }

bool MovingBoundary::penetrated(const Vec3r& from, const Vec3r& to, Real clearance, Vec3r& exit,
                                Vec3r& normal) const {
  // Relative motion: the start in the frame before the step, the end in the frame after it.
  Vec3r exitReference, normalReference;
  if (!mReference->penetrated(toReference(mPreviousPose, from), toReference(mPose, to), clearance, exitReference,
                              normalReference))
    return false;
  exit = toWorld(mPose, exitReference);
  normal = (mPose.rotation.cast<Real>() * normalReference);
  return true;
}

TriangleMesh MovingBoundary::surfaceMesh() const {
  TriangleMesh mesh = mReference->surfaceMesh();
  for (Eigen::Vector3f& v : mesh.vertices) v = mPose.apply(v.cast<double>()).cast<float>();
  const Eigen::Matrix3f r = mPose.rotation.cast<float>();
  for (Eigen::Vector3f& n : mesh.normals) n = r * n;
  return mesh;
}

void MovingBoundary::bounds(Vec3r& lo, Vec3r& hi) const {
  lo = Vec3r::Constant(std::numeric_limits<Real>::max());
  hi = -lo;
  for (const Vec3d& p : mHull) {
    const Vec3r w = mPose.apply(p).cast<Real>();
    lo = lo.cwiseMin(w);
    hi = hi.cwiseMax(w);
  }
}

template <typename F>
void MovingBoundary::forEachStateValue(F&& visit) {
  visit(mPose.rotation);
  visit(mPose.translation);
  visit(mPreviousPose.rotation);
  visit(mPreviousPose.translation);
  visit(mVelocity.linear);
  visit(mVelocity.angular);
  visit(mVelocity.center);
}

void MovingBoundary::save(std::ostream& out) const {
  const_cast<MovingBoundary*>(this)->forEachStateValue([&](const auto& value) { writePodValue(out, value); });
  if (mBody) mBody->save(out);
}

void MovingBoundary::restore(std::istream& in) {
  forEachStateValue([&](auto& value) { readPodValue(in, value, "moving solid state"); });
  if (mBody) mBody->restore(in);
}

} // namespace cascade
