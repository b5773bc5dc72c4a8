/// @file Boundary.h
/// @brief A solid the fluid cannot enter, handled by the SEED's two kinds of
///        virtual boundary particles (SEED section 2.2):
///        - type I (Monaghan 1994): particles sampled on the surface that
///          repel fluid closer than r0 with SEED (11);
///        - type II (Libersky & Petschke 1993): for a fluid particle closer than
///          kappa h to the surface, mirror images of the fluid near it across
///          the local tangent plane, with the same density and pressure and the
///          velocity mirrored (free slip) or reversed (no slip).
///
/// A mirror is an affine isometry x' = A x + b (one reflection, or for tank
/// corners the product of the reflections across two or three orthogonal
/// walls). All coordinates are world coordinates.
#pragma once

#include "libsph/Types.h"
#include "libsph/bodies/RigidPose.h"
#include "libsph/boundary/BoundarySampling.h"
#include "libsph/io/TriangleMesh.h"

#include <Eigen/Core>

#include <memory>
#include <string>
#include <vector>

namespace cascade {

/// One mirror map seen by a fluid particle: x' = linear * x + offset.
struct MirrorMap {
  Eigen::Matrix<Real, 3, 3> linear = Eigen::Matrix<Real, 3, 3>::Identity();
  Vec3r offset = Vec3r::Zero();
  std::uint32_t boundary = 0;   ///< index of the boundary in its Simulation (force attribution)
  /// A symmetry plane, not a wall (the side faces of a slab that stands for a
  /// 2-D flow): its images always mirror the velocity (free slip) and it exerts
  /// no wall shear, whatever BoundarySettings::slip says. A product of maps is a
  /// symmetry only if all its factors are.
  bool symmetry = false;
  /// Velocity of the wall where the map's plane touches it (zero for a solid at
  /// rest). A moving wall's images carry it: free slip v' = w + L (v - w), no
  /// slip v' = 2 w - v, so viscosity, no-slip and DFSPH's divergence see the wall
  /// move (its source term).
  Vec3r wallVelocity = Vec3r::Zero();
  /// Only sources in front of the plane (on the particle's side) have images: the map
  /// of a solid with convex edges (a mesh), where fluid beside the solid lies behind
  /// the tangent plane and its images would land in the fluid (ghosts on top of real
  /// water near the edge: a cube held in water lost 4-7 % of its buoyancy to them).
  /// A single reflection only.
  bool frontOnly = false;
  /// A product of a front-only map with another solid's (a junction's map,
  /// BoundaryParticles) images only the sources in front of the front-only factor's
  /// plane: frontNormal . s > frontDistance. Zero for a single reflection, whose own
  /// plane is that plane.
  Vec3r frontNormal = Vec3r::Zero();
  Real frontDistance = 0;

  /// True if `source` has no image under a frontOnly map seen by the particle at x.
  bool behind(const Vec3r& x, const Vec3r& source) const {
    if (!frontOnly) return false;
    if (frontNormal.isZero()) return (source - apply(source)).dot(x - apply(x)) < 0;
    return (frontNormal.dot(source) - frontDistance) * (frontNormal.dot(x) - frontDistance) < 0;
  }

  /// The image's velocity of a source moving at v (free slip or no slip).
  Vec3r imageVelocity(const Vec3r& v, bool noSlip) const {
    return noSlip && !symmetry ? Vec3r(Real(2) * wallVelocity - v) : Vec3r(wallVelocity + linear * (v - wallVelocity));
  }
  Vec3r apply(const Vec3r& x) const { return linear * x + offset; }
  /// Reflection across the plane through `point` with unit `normal`.
  static MirrorMap reflection(const Vec3r& point, const Vec3r& normal, std::uint32_t boundary);
  /// This map applied after `first`.
  MirrorMap after(const MirrorMap& first) const;
};

/// An affine placement: world = translation + rotation * (scale * local).
struct Transform {
  Vec3r translation = Vec3r::Zero();
  Eigen::Matrix<Real, 3, 3> rotation = Eigen::Matrix<Real, 3, 3>::Identity();
  Real scale = Real(1);

  Vec3r apply(const Vec3r& local) const { return translation + rotation * (scale * local); }
  Vec3r applyInverse(const Vec3r& world) const {
    return rotation.transpose() * (world - translation) / scale;
  }
  /// Rotation from Euler angles in degrees, applied about x, then y, then z.
  static Eigen::Matrix<Real, 3, 3> rotationFromEulerDegrees(const Vec3r& degrees);
};

class Boundary {
public:
  virtual ~Boundary() = default;

  /// The name the scene gives it ("tank", "slope", "bunny"); probes find it by name.
  const std::string& name() const { return mName; }
  void setName(std::string name) { mName = std::move(name); }

  /// Kind of solid: "plane", "box", "tank", "mesh".
  virtual std::string kind() const = 0;

  /// Type I particles: points on the surface with no gap wider than maxGap.
  virtual void sampleSurface(Real maxGap, std::vector<Vec3r>& samples) const = 0;

  /// The same type I particles, those on flat pieces as lattices (searched
  /// without a search structure), the rest appended to `points`. The lattices'
  /// points, appended in order, then `points` are sampleSurface()'s samples
  /// (as a set). Default: all as points.
  virtual void sampleSurfaceLattices(Real maxGap, std::vector<SampleLattice>& lattices,
                                     std::vector<Vec3r>& points) const {
    (void)lattices;
    sampleSurface(maxGap, points);
  }

  /// Type II: the mirror maps a fluid particle at x sees (surfaces closer than
  /// range = kappa h), appended to `maps` tagged with `boundaryIndex`.
  virtual void mirrorMaps(const Vec3r& x, Real range, std::uint32_t boundaryIndex,
                          std::vector<MirrorMap>& maps) const = 0;

  /// True if x lies inside the solid (where no fluid may be).
  virtual bool isInside(const Vec3r& x) const = 0;
  /// isInside() for a point near the surface (the junctions' probes, addJunctionMaps):
  /// a mesh answers from its closest face within `reach` (none there: false) instead
  /// of its winding number over every triangle. Default: isInside(x).
  virtual bool isInsideNear(const Vec3r& x, Real reach) const {
    (void)reach;
    return isInside(x);
  }

  /// Simulation's guard after each step: true if a particle that moved from `from`
  /// (outside) to `to` entered the solid on the way (ended inside, or passed through
  /// a thin part); then `exit` is a point outside where it may go (about `clearance`
  /// off the surface where it entered) and `normal` the outward direction there.
  /// Default: isInside(to), back to `from`, the normal against the move.
  virtual bool penetrated(const Vec3r& from, const Vec3r& to, Real clearance, Vec3r& exit, Vec3r& normal) const {
    (void)clearance;
    if (!isInside(to) || isInside(from)) return false;
    exit = from;
    const Vec3r back = from - to;
    normal = back.norm() > 0 ? Vec3r(back.normalized()) : Vec3r::Zero();
    return true;
  }

  /// A rigid body's contacts: a point already inside the solid (left there by an
  /// earlier step, so penetrated() sees no entry): true with `exit` about `clearance`
  /// outside the nearest surface and `normal` the outward direction there. Default:
  /// none (solids whose insides no body point reaches by a path penetrated() misses).
  virtual bool escape(const Vec3r& x, Real clearance, Vec3r& exit, Vec3r& normal) const {
    (void)x, (void)clearance, (void)exit, (void)normal;
    return false;
  }

  // --- motion (a solid at rest answers with the defaults) ---
  /// True if the solid moves (MovingBoundary, DeformingMeshBoundary): its type I samples
  /// are kept in its reference frame and placed by pose() each step, or made per frame
  /// interval (deformation()).
  virtual bool moves() const { return false; }
  /// Pose of the reference geometry this step (identity for a solid at rest).
  virtual RigidPose pose() const { return RigidPose(); }
  /// Velocity of the solid at world point x this step.
  virtual Vec3r velocityAt(const Vec3r& x) const {
    (void)x;
    return Vec3r::Zero();
  }
  /// Type I samples in the reference frame (a moving solid's; the static ones are
  /// sampleSurfaceLattices()'s, already in world coordinates).
  virtual void sampleReference(Real maxGap, std::vector<Vec3r>& samples) const { sampleSurface(maxGap, samples); }
  /// Fastest speed of any point of the solid now, m/s (for the time step).
  virtual double maxSurfaceSpeed() const { return 0; }
  /// Fastest speed any point of a prescribed motion or deformation reaches over all
  /// time, m/s (part of the scene's expected speed; 0 for a rigid body, moved by the water).
  virtual double maxMotionSpeed() const { return 0; }

  /// A solid that changes shape (a deforming mesh sequence) is between two frames of
  /// its sequence: its type I samples are made per frame interval, as the same surface
  /// points at the interval's start and end (sampleDeformation), and placed each step
  /// by linear interpolation, x = start + weight (end - start), moving at
  /// (end - start) rate. A rigid solid answers interval -1.
  struct Deformation {
    long interval = -1;  ///< changes when the solid enters another frame interval (re-sample then)
    Real weight = 0;     ///< 0 at the interval's start, 1 at its end
    Real rate = 0;       ///< 1 / the interval's duration, 1/s (0 while a frame holds)
  };
  virtual Deformation deformation() const { return {}; }
  /// The samples of the current frame interval at its start and at its end (the same count).
  virtual void sampleDeformation(Real maxGap, std::vector<Vec3r>& start, std::vector<Vec3r>& end) const {
    (void)maxGap;
    (void)start;
    (void)end;
  }

  /// The solid's surface as triangles in world coordinates (one group, named name()).
  virtual TriangleMesh surfaceMesh() const = 0;

  /// True if mirrorMaps() gives maps only within 2 `range` of surfaceMesh()'s triangles
  /// (a tank's wall mirrors up to `range` beyond its edges, within sqrt 3 range of it;
  /// false: an unbounded plane mirrors everywhere along it).
  virtual bool mirrorsNearSurfaceMeshOnly() const { return true; }

  /// For a solid not bounded so (mirrorsNearSurfaceMeshOnly() false): false only if
  /// mirrorMaps() gives no map, for `range`, to any point within `slack` of x. The
  /// default, true, marks the solid everywhere in the proximity grid.
  virtual bool mayMirrorNear(const Vec3r& x, Real slack, Real range) const {
    (void)x;
    (void)slack;
    (void)range;
    return true;
  }

  /// Axis-aligned bounds of the surface.
  virtual void bounds(Vec3r& lo, Vec3r& hi) const = 0;

private:
  std::string mName;
};

using BoundaryPtr = std::unique_ptr<Boundary>;

} // namespace cascade
