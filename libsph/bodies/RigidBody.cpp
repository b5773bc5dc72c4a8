#include "libsph/bodies/RigidBody.h"

#include "libsph/io/BinaryPod.h"

#include <algorithm>
#include <cmath>
#include <istream>
#include <ostream>

namespace cascade {

RigidBody::RigidBody(const MassProperties& reference, double friction, double restitution)
    : mReference(reference), mFriction(friction), mRestitution(restitution), mCenter(reference.centerOfMass) {
  mInverseInertia = reference.inertia.inverse();
}

RigidPose RigidBody::pose() const {
  RigidPose pose;
  pose.rotation = mOrientation.toRotationMatrix();
  pose.translation = mCenter - pose.rotation * mReference.centerOfMass;
  return pose;
}

RigidVelocity RigidBody::velocity() const {
  RigidVelocity v;
  v.linear = mVelocity;
  v.angular = mAngularVelocity;
  v.center = mCenter;
  return v;
}

Mat3d RigidBody::worldInverseInertia() const {
  const Mat3d r = mOrientation.toRotationMatrix();
  return r * mInverseInertia * r.transpose();
}

void RigidBody::integrate(const Vec3d& force, const Vec3d& torque, double dt) {
  // Symplectic Euler: velocities from the forces at the step's start, then the pose.
  mVelocity += (dt / mReference.mass) * force;
  const Mat3d r = mOrientation.toRotationMatrix();
  const Mat3d inertia = r * mReference.inertia * r.transpose();
  const Mat3d inverse = r * mInverseInertia * r.transpose();
  mAngularVelocity += dt * (inverse * (torque - mAngularVelocity.cross(inertia * mAngularVelocity)));
  mCenter += dt * mVelocity;
  // dq/dt = (1/2) (0, w) q, then back to unit length
  const Eigen::Quaterniond spin(0, mAngularVelocity.x(), mAngularVelocity.y(), mAngularVelocity.z());
  Eigen::Quaterniond q = mOrientation;
  const Eigen::Quaterniond dq = spin * q;
  q.coeffs() += (0.5 * dt) * dq.coeffs();
  mOrientation = q.normalized();
}

void RigidBody::resolveContacts(const std::vector<RigidContact>& contacts) {
  std::vector<ContactConstraint> group;
  group.reserve(contacts.size());
  for (const RigidContact& c : contacts) group.push_back(contactConstraint(*this, nullptr, c));
  solveContacts(group);
}

ContactConstraint contactConstraint(RigidBody& a, RigidBody* b, const RigidContact& c, const Vec3d& surfaceVelocity) {
  ContactConstraint constraint;
  constraint.a = &a;
  constraint.b = b;
  constraint.point = c.point;
  constraint.normal = c.normal;
  constraint.depth = c.depth;
  constraint.surfaceVelocity = b ? Vec3d::Zero() : surfaceVelocity;
  constraint.friction = b ? std::sqrt(a.friction() * b->friction()) : a.friction();
  constraint.restitution = b ? std::max(a.restitution(), b->restitution()) : a.restitution();
  return constraint;
}

void solveContacts(const std::vector<ContactConstraint>& contacts) {
  if (contacts.empty()) return;
  // The bodies of the group, in order of first appearance (deterministic).
  std::vector<RigidBody*> bodies;
  const auto indexOf = [&](RigidBody* body) -> long {
    if (!body) return -1;
    for (std::size_t k = 0; k < bodies.size(); ++k)
      if (bodies[k] == body) return long(k);
    bodies.push_back(body);
    return long(bodies.size() - 1);
  };
  std::vector<std::pair<long, long>> pairs;
  for (const ContactConstraint& c : contacts) pairs.emplace_back(indexOf(c.a), indexOf(c.b));
  std::vector<double> inverseMass(bodies.size());
  std::vector<Mat3d> inverseInertia(bodies.size());
  for (std::size_t k = 0; k < bodies.size(); ++k) {
    inverseMass[k] = 1.0 / bodies[k]->mass();
    inverseInertia[k] = bodies[k]->worldInverseInertia();
  }
  // Positions: Gauss-Seidel passes over the separations.
  std::vector<Vec3d> shift(bodies.size(), Vec3d::Zero());
  for (int pass = 0; pass < 16; ++pass)
    for (std::size_t k = 0; k < contacts.size(); ++k) {
      const ContactConstraint& c = contacts[k];
      const auto [a, b] = pairs[k];
      const double wa = inverseMass[std::size_t(a)], wb = b >= 0 ? inverseMass[std::size_t(b)] : 0.0;
      const double moved = (shift[std::size_t(a)] - (b >= 0 ? shift[std::size_t(b)] : Vec3d::Zero())).dot(c.normal);
      const double missing = c.depth - moved;
      if (missing <= 0) continue;
      shift[std::size_t(a)] += (missing * wa / (wa + wb)) * c.normal;
      if (b >= 0) shift[std::size_t(b)] -= (missing * wb / (wa + wb)) * c.normal;
    }
  for (std::size_t k = 0; k < bodies.size(); ++k) bodies[k]->shift(shift[k]);
  // Velocities: sequential impulses on the accumulated impulse per contact.
  const auto pointOf = [&](std::size_t k) {  // moved with body a
    return Vec3d(contacts[k].point + shift[std::size_t(pairs[k].first)]);
  };
  const auto relativeVelocity = [&](std::size_t k, const Vec3d& p) {
    const RigidBody& a = *contacts[k].a;
    const Vec3d va = a.linearVelocity() + a.angularVelocity().cross(p - a.centerOfMass());
    if (!contacts[k].b) return Vec3d(va - contacts[k].surfaceVelocity);
    const RigidBody& b = *contacts[k].b;
    return Vec3d(va - b.linearVelocity() - b.angularVelocity().cross(p - b.centerOfMass()));
  };
  const auto effectiveInverseMass = [&](std::size_t k, const Vec3d& p, const Vec3d& d) {
    const auto [a, b] = pairs[k];
    const Vec3d ra = p - contacts[k].a->centerOfMass();
    double w = inverseMass[std::size_t(a)] + d.dot((inverseInertia[std::size_t(a)] * ra.cross(d)).cross(ra));
    if (b >= 0) {
      const Vec3d rb = p - contacts[k].b->centerOfMass();
      w += inverseMass[std::size_t(b)] + d.dot((inverseInertia[std::size_t(b)] * rb.cross(d)).cross(rb));
    }
    return w;
  };
  const auto push = [&](std::size_t k, const Vec3d& p, const Vec3d& j) {  // j on a, -j on b
    RigidBody& a = *contacts[k].a;
    a.applyImpulse(j, (p - a.centerOfMass()).cross(j));
    if (RigidBody* b = contacts[k].b) b->applyImpulse(-j, (p - b->centerOfMass()).cross(-j));
  };
  std::vector<double> normalImpulse(contacts.size(), 0.0), bounce(contacts.size(), 0.0);
  std::vector<Vec3d> frictionImpulse(contacts.size(), Vec3d::Zero());
  for (std::size_t k = 0; k < contacts.size(); ++k) {
    const double approach = relativeVelocity(k, pointOf(k)).dot(contacts[k].normal);
    bounce[k] = approach < 0 ? -contacts[k].restitution * approach : 0.0;
  }
  for (int iteration = 0; iteration < 16; ++iteration)
    for (std::size_t k = 0; k < contacts.size(); ++k) {
      const Vec3d p = pointOf(k), n = contacts[k].normal;
      const double vn = relativeVelocity(k, p).dot(n);
      const double total = std::max(0.0, normalImpulse[k] + (bounce[k] - vn) / effectiveInverseMass(k, p, n));
      push(k, p, (total - normalImpulse[k]) * n);
      normalImpulse[k] = total;
      const Vec3d relative = relativeVelocity(k, p);
      const Vec3d tangential = relative - relative.dot(n) * n;
      const double slide = tangential.norm();
      if (slide <= 0) continue;
      const Vec3d t = tangential / slide;
      Vec3d friction = frictionImpulse[k] - (slide / effectiveInverseMass(k, p, t)) * t;
      const double limit = contacts[k].friction * normalImpulse[k];
      if (friction.norm() > limit) friction *= limit / friction.norm();
      push(k, p, friction - frictionImpulse[k]);
      frictionImpulse[k] = friction;
    }
}

void RigidBody::save(std::ostream& out) const {
  writePodValue(out, mCenter);
  writePodValue(out, Eigen::Vector4d(mOrientation.coeffs()));
  writePodValue(out, mVelocity);
  writePodValue(out, mAngularVelocity);
}

void RigidBody::restore(std::istream& in) {
  Eigen::Vector4d coefficients;
  readPodValue(in, mCenter, "rigid body state");
  readPodValue(in, coefficients, "rigid body state");
  mOrientation.coeffs() = coefficients;
  readPodValue(in, mVelocity, "rigid body state");
  readPodValue(in, mAngularVelocity, "rigid body state");
}

} // namespace cascade
