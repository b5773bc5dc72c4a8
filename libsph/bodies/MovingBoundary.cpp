#include "libsph/bodies/MovingBoundary.h"

#include "libsph/bodies/DeformingMesh.h"

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

/// The surface sampled contactPointGap() apart.
std::vector<Vec3d> contactPointsOf(const Boundary& reference) {
  Vec3r lo, hi;
  reference.bounds(lo, hi);
  std::vector<Vec3d> points;
  for (const Vec3r& p : sampleTriangles(reference.surfaceMesh(), Real(contactPointGap(double((hi - lo).norm())))))
    points.push_back(p.cast<double>());
  return points;
}

} // namespace

MovingBoundary::MovingBoundary(BoundaryPtr reference, KinematicMotion motion)
    : mReference(std::move(reference)), mMotion(std::move(motion)), mHull(hullOf(*mReference)),
      mContactPoints(contactPointsOf(*mReference)) {
  setName(mReference->name());
  moveTo(0.0);
  mPreviousPose = mPose;
  for (const Vec3d& p : mHull) mRadius = std::max(mRadius, (mPose.apply(p) - mVelocity.center).norm());
}

MovingBoundary::MovingBoundary(BoundaryPtr reference, RigidBody body)
    : mReference(std::move(reference)), mBody(std::move(body)), mHull(hullOf(*mReference)),
      mContactPoints(contactPointsOf(*mReference)) {
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
  clearContacts(before, solids, clearance);
  mPreviousPose = before;
}

namespace {
/// A point that moved from `from` to `to` this step, tested a clearance further (a
/// speculative contact: a point resting a clearance off a surface touches it, so a
/// body at rest on it stays at rest): the contact it makes with `solid`, if any; its
/// normal out of the solid, its depth how far the point must go along it. A point
/// that was inside already (a contact an earlier step left unresolved: the position
/// passes share it between bodies that the water and other contacts move again) goes
/// out through the nearest surface; penetrated() sees only entries, and such a point
/// would otherwise stay inside for good and the bodies sink into each other.
bool contactOf(const Boundary& solid, const Vec3d& from, const Vec3d& to, Real clearance, RigidContact& contact) {
  const Vec3r start = from.cast<Real>(), end = to.cast<Real>();
  const Vec3r move = end - start;
  const Real length = move.norm();
  const Vec3r reach = length > 0 ? Vec3r(end + (clearance / length) * move) : end;
  Vec3r exit, normal;
  if (!solid.penetrated(start, reach, clearance, exit, normal) && !solid.escape(end, clearance, exit, normal))
    return false;
  contact = RigidContact{to, normal.cast<double>().normalized(), double((exit - end).dot(normal))};
  return true;
}
} // namespace

void MovingBoundary::clearContacts(const RigidPose& from, const std::vector<const Boundary*>& solids, Real clearance) {
  RigidBody& body = *mBody;
  const RigidPose after = body.pose();
  std::vector<RigidContact> contacts;
  RigidContact contact;
  for (const Vec3d& p : mHull)
    for (const Boundary* solid : solids)
      if (contactOf(*solid, from.apply(p), after.apply(p), clearance, contact)) contacts.push_back(contact);
  const Vec3d centerBefore = body.centerOfMass();
  body.resolveContacts(contacts);
  mPose = body.pose();
  mVelocity = body.velocity();
  // Kept for contact groups with other solids, moved with the body.
  const Vec3d shift = body.centerOfMass() - centerBefore;
  mRestingContacts = contacts;
  for (RigidContact& c : mRestingContacts) {
    c.point += shift;
    c.depth -= shift.dot(c.normal);
  }
}

void MovingBoundary::settle(const RigidPose& from, const std::vector<const Boundary*>& atRest, Real clearance) {
  if (!mBody) return;
  const std::vector<RigidContact> resting = mRestingContacts;
  clearContacts(from, atRest, clearance);
  if (mRestingContacts.empty()) mRestingContacts = resting;  // still resting where it was
}

void MovingBoundary::contactsWith(const Boundary& other, Real clearance, std::vector<RigidContact>& contacts) const {
  RigidContact contact;
  // This body's points into the other (which answers for its own motion over the step).
  for (const Vec3d& p : mContactPoints)
    if (contactOf(other, mPreviousPose.apply(p), mPose.apply(p), clearance, contact)) contacts.push_back(contact);
  // The other's points into this body: the contact's normal turned round (the way this body must go).
  const auto theirs = [&](const Vec3d& from, const Vec3d& to) {
    if (!contactOf(*this, from, to, clearance, contact)) return;
    contact.normal = -contact.normal;
    contacts.push_back(contact);
  };
  if (const auto* moving = dynamic_cast<const MovingBoundary*>(&other)) {
    for (const Vec3d& p : moving->contactPoints()) theirs(moving->mPreviousPose.apply(p), moving->mPose.apply(p));
  } else if (const auto* deforming = dynamic_cast<const DeformingMeshBoundary*>(&other)) {
    const std::vector<Eigen::Vector3f>& now = deforming->current().mesh().vertices;
    const std::vector<Eigen::Vector3f>& before = deforming->previousVertices().empty() ? now : deforming->previousVertices();
    for (const SurfacePoint& p : deforming->contactPoints()) theirs(p.on(before), p.on(now));
  }
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

bool MovingBoundary::isInsideNear(const Vec3r& x, Real reach) const {
  return mReference->isInsideNear(toReference(mPose, x), reach);
}

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

bool MovingBoundary::escape(const Vec3r& x, Real clearance, Vec3r& exit, Vec3r& normal) const {
  Vec3r exitReference, normalReference;
  if (!mReference->escape(toReference(mPose, x), clearance, exitReference, normalReference)) return false;
  exit = toWorld(mPose, exitReference);
  normal = mPose.rotation.cast<Real>() * normalReference;
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
