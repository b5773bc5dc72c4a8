/// @file MovingBoundary.h
/// @brief A solid that moves: its geometry where the scene placed it (the
///        reference, any Boundary, in practice a MeshBoundary) carried by a
///        rigid pose, either prescribed (KinematicMotion: keyframes, a piston)
///        or integrated from the fluid's force and gravity (RigidBody, two-way
///        coupling, Akinci et al. 2012).
///
/// Every query is answered in the reference frame and turned back: a world
/// point x is x_ref = R^T (x - t); mirror maps M_ref are conjugated,
/// M = P M_ref P^-1; type I samples are made once in the reference frame and
/// placed each step (BoundaryParticles), never re-sampled. Mirror maps carry
/// the wall's velocity at their plane (MirrorMap::wallVelocity), so images see
/// the wall move. The guard (penetrated) compares a particle's start in the
/// pose before the step with its end in the pose after it: a wall that moved
/// onto a particle counts as the particle entering it.
#pragma once

#include "libsph/bodies/KinematicMotion.h"
#include "libsph/bodies/RigidBody.h"
#include "libsph/boundary/Boundary.h"

#include <memory>
#include <optional>

namespace cascade {

class MovingBoundary final : public Boundary {
public:
  /// A solid moved by `motion` (pose at time 0 applied at once).
  MovingBoundary(BoundaryPtr reference, KinematicMotion motion);
  /// A rigid body (pose identity at the start, at rest).
  MovingBoundary(BoundaryPtr reference, RigidBody body);

  std::string kind() const override { return "moving " + mReference->kind(); }
  void sampleSurface(Real maxGap, std::vector<Vec3r>& samples) const override;
  void mirrorMaps(const Vec3r& x, Real range, std::uint32_t boundaryIndex,
                  std::vector<MirrorMap>& maps) const override;
  bool isInside(const Vec3r& x) const override;
  bool isInsideNear(const Vec3r& x, Real reach) const override;
  bool penetrated(const Vec3r& from, const Vec3r& to, Real clearance, Vec3r& exit, Vec3r& normal) const override;
  /// The reference solid's escape, in the pose now.
  bool escape(const Vec3r& x, Real clearance, Vec3r& exit, Vec3r& normal) const override;
  TriangleMesh surfaceMesh() const override;
  void bounds(Vec3r& lo, Vec3r& hi) const override;

  bool moves() const override { return true; }
  RigidPose pose() const override { return mPose; }
  Vec3r velocityAt(const Vec3r& x) const override { return mVelocity.at(x.cast<double>()).cast<Real>(); }
  void sampleReference(Real maxGap, std::vector<Vec3r>& samples) const override {
    mReference->sampleSurface(maxGap, samples);
  }

  const Boundary& reference() const { return *mReference; }
  bool isDynamic() const { return mBody.has_value(); }
  const RigidBody* body() const { return mBody ? &*mBody : nullptr; }
  RigidBody* body() { return mBody ? &*mBody : nullptr; }
  const RigidVelocity& velocity() const { return mVelocity; }
  /// Centre of mass (a rigid body) or the motion's origin, world.
  Vec3d center() const { return mVelocity.center; }
  /// Fastest speed of any point of the solid now, m/s (for the time step).
  double maxSurfaceSpeed() const override;
  /// Fastest speed of any point of a prescribed motion over all time (0 for a rigid
  /// body), m/s: part of the scene's expected speed.
  double maxMotionSpeed() const override;

  /// Moves the solid to time t (a kinematic motion) or by one step dt under the
  /// fluid's force and torque (about the centre of mass) plus gravity, clearing
  /// contacts with `solids` (those at rest). The pose before is kept for penetrated().
  void advance(double t, double dt, const Vec3d& fluidForce, const Vec3d& fluidTorque, const Vec3d& gravity,
               const std::vector<const Boundary*>& solids, Real clearance);
  /// Contacts of this rigid body with another moving solid, after both moved this step
  /// (another rigid body, a solid moved as prescribed, a deforming mesh): this body's
  /// contact points that entered it and its points that entered this body, each with
  /// the normal this body must go along. Appended to `contacts`.
  void contactsWith(const Boundary& other, Real clearance, std::vector<RigidContact>& contacts) const;
  /// The contacts with the solids at rest that the last step cleared (where they are now).
  const std::vector<RigidContact>& restingContacts() const { return mRestingContacts; }
  /// After the body was moved by a contact group (solveContacts): takes its new state and
  /// clears the solids at rest again for the move from `from`.
  void settle(const RigidPose& from, const std::vector<const Boundary*>& atRest, Real clearance);
  /// A rigid body takes an impulse (N s) and angular impulse about its centre of mass
  /// (N m s) at once: the guard's push on particles it had moved onto. Others ignore it.
  void applyImpulse(const Vec3d& impulse, const Vec3d& angular);
  /// Sets the pose for time t without a step (start, restore): kinematic only.
  void moveTo(double t);

  /// Hull points (reference frame) used for contacts: the reference mesh's vertices.
  const std::vector<Vec3d>& hull() const { return mHull; }
  /// Points (reference frame) used for contacts with other moving solids: the
  /// reference surface sampled about a twentieth of its size apart (vertices, edges
  /// and faces: stacked boxes touch face to face, with no vertex inside the other).
  const std::vector<Vec3d>& contactPoints() const { return mContactPoints; }

  void save(std::ostream& out) const;
  void restore(std::istream& in);

  RigidPose previousPose() const { return mPreviousPose; }

private:
  void setPose(const RigidPose& pose, const RigidVelocity& velocity);
  /// Contacts of the body's hull points moving from pose `from` to the body's pose now
  /// with `solids` (speculative by `clearance`), resolved; then the state from the body.
  void clearContacts(const RigidPose& from, const std::vector<const Boundary*>& solids, Real clearance);
  /// Calls visit(value) for each value of the state a checkpoint keeps, in order.
  template <typename F>
  void forEachStateValue(F&& visit);
  BoundaryPtr mReference;
  std::optional<KinematicMotion> mMotion;
  std::optional<RigidBody> mBody;
  RigidPose mPose, mPreviousPose;
  RigidVelocity mVelocity;
  std::vector<Vec3d> mHull, mContactPoints;
  std::vector<RigidContact> mRestingContacts;
  double mRadius = 0;  ///< largest distance of a hull point from the reference centre
};

} // namespace cascade
