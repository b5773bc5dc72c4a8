/// @file RigidBody.h
/// @brief A rigid body that water and gravity move (two-way coupling, Akinci et
///        al. 2012, "Versatile rigid-fluid coupling for incompressible SPH",
///        section 4): the fluid's force and torque on its boundary particles,
///        summed by the solvers (StepContext::obstacleForce / obstacleMoment),
///        plus gravity, advance the centre of mass and a unit quaternion by
///        symplectic Euler (the body's velocities first, then its pose; the
///        gyroscopic term w x I w explicit).
///
/// Contact with the solids at rest (tank, planes, slopes, static obstacles):
/// the body's hull vertices that a step carried into a solid give contact
/// points. The body is moved out along the contacts' normals (the smallest
/// translation that clears every contact), then sequential impulses (Catto
/// 2005, "Iterative dynamics with temporal coherence") remove the approach
/// velocity at each point (restitution e) with Coulomb friction mu, on the
/// accumulated impulse. So a body comes to rest on the floor instead of sinking.
/// Bodies meet each other, and solids that move as prescribed, in groups solved
/// together with their contacts with the solids at rest (solveContacts).
#pragma once

#include "libsph/bodies/MassProperties.h"
#include "libsph/bodies/RigidPose.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <iosfwd>
#include <vector>

namespace cascade {

/// A point of the body inside another solid or about to enter it: `point` (world)
/// is to move `depth` along `normal` (out of the other solid, unit) to clear it
/// (depth <= 0: not in yet; only its approach velocity is stopped).
struct RigidContact {
  Vec3d point = Vec3d::Zero();
  Vec3d normal = Vec3d::UnitZ();
  double depth = 0;
};

class RigidBody {
public:
  /// `reference`: the body's mass properties where the scene placed it (pose identity).
  RigidBody(const MassProperties& reference, double friction, double restitution);

  double mass() const { return mReference.mass; }
  const MassProperties& reference() const { return mReference; }

  // --- state ---
  Vec3d centerOfMass() const { return mCenter; }
  const Eigen::Quaterniond& orientation() const { return mOrientation; }
  Vec3d linearVelocity() const { return mVelocity; }
  Vec3d angularVelocity() const { return mAngularVelocity; }
  void setVelocity(const Vec3d& linear, const Vec3d& angular) { mVelocity = linear, mAngularVelocity = angular; }

  /// Reference -> world: x = R (x_ref - c_ref) + c.
  RigidPose pose() const;
  RigidVelocity velocity() const;
  /// Inverse inertia tensor in world axes, R I^-1 R^T.
  Mat3d worldInverseInertia() const;

  /// One step under `force` and `torque` (about the centre of mass), N and N m.
  void integrate(const Vec3d& force, const Vec3d& torque, double dt);
  /// An impulse (N s) and angular impulse about the centre of mass (N m s), at once.
  void applyImpulse(const Vec3d& impulse, const Vec3d& angular) {
    mVelocity += impulse / mReference.mass;
    mAngularVelocity += worldInverseInertia() * angular;
  }
  /// Clears the contacts with solids at rest (positions, then velocities; solveContacts).
  void resolveContacts(const std::vector<RigidContact>& contacts);
  /// Moves the centre of mass by `shift` (a contact's position correction).
  void shift(const Vec3d& shift) { mCenter += shift; }
  double friction() const { return mFriction; }
  double restitution() const { return mRestitution; }

  /// Exact binary save / restore of the state.
  void save(std::ostream& out) const;
  void restore(std::istream& in);

private:
  MassProperties mReference;
  Mat3d mInverseInertia = Mat3d::Zero();  ///< reference frame, about the centre of mass
  double mFriction = 0, mRestitution = 0;
  Vec3d mCenter = Vec3d::Zero();
  Eigen::Quaterniond mOrientation = Eigen::Quaterniond::Identity();
  Vec3d mVelocity = Vec3d::Zero(), mAngularVelocity = Vec3d::Zero();
};

/// One contact of a group solved together (solveContacts): body `a` against body `b`,
/// or (b null) against a solid whose surface moves at `surfaceVelocity` at the point
/// (zero for one at rest). `normal` is the way `a` must go, `depth` how far (<= 0: not
/// in yet; only the approach velocity is stopped).
struct ContactConstraint {
  RigidBody* a = nullptr;
  RigidBody* b = nullptr;
  Vec3d point = Vec3d::Zero(), normal = Vec3d::UnitZ();
  double depth = 0;
  Vec3d surfaceVelocity = Vec3d::Zero();
  double friction = 0, restitution = 0;
};

/// The contact `c` of body `a` as a constraint: against body `b` (friction sqrt(mu_a mu_b),
/// restitution the larger of the two) or, b null, against a solid whose surface moves at
/// `surfaceVelocity` at the point (a's friction and restitution).
ContactConstraint contactConstraint(RigidBody& a, RigidBody* b, const RigidContact& c,
                                    const Vec3d& surfaceVelocity = Vec3d::Zero());

/// A solid's contact points with other moving solids are its surface sampled this far
/// apart: a twentieth of the diagonal of its bounds (vertices, edges and faces, so
/// that boxes stacked face to face touch).
inline double contactPointGap(double boundsDiagonal) { return std::max(boundsDiagonal / 20, 1e-4); }

/// Clears a group of contacts between bodies and the solids around them at once, so
/// that a stack rests (the floor holds the lower box while the upper one is pushed
/// off it). Positions first: passes over the contacts, each moving its two bodies
/// apart along the normal by what is missing, shared in proportion to their inverse
/// masses (a solid that is not a body takes none). Then sequential impulses (Catto
/// 2005) on the relative velocity at each point, equal and opposite on two bodies,
/// with the contact's restitution and Coulomb friction: momentum is exchanged, not made.
void solveContacts(const std::vector<ContactConstraint>& contacts);

} // namespace cascade
