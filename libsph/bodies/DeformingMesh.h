/// @file DeformingMesh.h
/// @brief A deforming obstacle: a closed triangle mesh given once per output frame
///        (an OBJ sequence, "assets/paddle.####.obj"), its triangles the same in
///        every frame and its vertices moving. Frame k stands at t = k / fps, as the
///        bake's own frames do (OUT/geometry/solids.NNNN.obj repeats it); an optional
///        frame 0 stands at t = 0, else frame 1 holds before 1 / fps; the last frame
///        holds after its time.
///
/// Between frames k and k + 1 the vertices move linearly, x = x_k + w (x_k+1 - x_k),
/// w = t fps - k, so every surface point moves at (x_k+1 - x_k) fps (the velocity a
/// renderer's motion blur gives the same sequence). Type I samples are made when the
/// solid enters a frame interval, on frame k's surface, as vertex weights
/// (SurfacePoint), and found again on frame k + 1: each step places them by the same
/// interpolation (Boundary::deformation), never re-sampled within the interval. Mirror
/// maps, the inside test and the guard use the mesh at the step's time; mirrors carry
/// the wall's velocity at their plane. The guard sees a wall that moved onto a
/// particle: the particle's start is carried by the move of the surface point nearest
/// it before the move is tested. The surface's search grids are built once per frame
/// interval, with room for its vertices' moves (MeshBoundary::moveVertices), and
/// refitted each step.
#pragma once

#include "libsph/boundary/MeshBoundary.h"

#include <filesystem>
#include <limits>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

namespace cascade {

/// The frames of a deforming mesh, in world coordinates.
struct MeshSequence {
  std::vector<std::array<std::uint32_t, 3>> triangles;  ///< outward oriented, the same in every frame
  std::vector<std::vector<Eigen::Vector3f>> frames;     ///< vertices of frames firstFrame, firstFrame + 1, ...
  int firstFrame = 1;                                   ///< 0 or 1
  double fps = 30;

  int lastFrame() const { return firstFrame + int(frames.size()) - 1; }
  /// Vertices of frame k (clamped to the frames there are).
  const std::vector<Eigen::Vector3f>& frame(long k) const;
};

/// The sequence's first frame: 0 if the pattern's frame-0 file exists, else 1.
int sequenceFirstFrame(const std::string& pattern);

/// The file of frame k of a sequence pattern: the run of '#' replaced by k, zero
/// padded to the run's length ("paddle.####.obj", 7: "paddle.0007.obj").
std::string sequenceFramePath(const std::string& pattern, long k);

/// Loads frames 0 (if its file exists) or 1 to lastFrame of an OBJ sequence, placed
/// by `transform`. Coincident vertices of the first frame are welded in every frame.
/// InputError (naming the file and `context`, the scene's JSON path) on a missing or
/// unreadable frame, a frame whose triangles differ from the first's, an open mesh, a
/// frame turned inside out, or vertices welded in the first frame that part later.
MeshSequence loadMeshSequence(const std::string& pattern, int lastFrame, double fps, const Transform& transform,
                              const std::string& context);

class DeformingMeshBoundary final : public Boundary {
public:
  /// At t = 0.
  explicit DeformingMeshBoundary(MeshSequence sequence);
  ~DeformingMeshBoundary() override;

  std::string kind() const override { return "deforming mesh"; }
  void sampleSurface(Real maxGap, std::vector<Vec3r>& samples) const override;
  void mirrorMaps(const Vec3r& x, Real range, std::uint32_t boundaryIndex,
                  std::vector<MirrorMap>& maps) const override;
  bool isInside(const Vec3r& x) const override;
  bool isInsideNear(const Vec3r& x, Real reach) const override;
  bool penetrated(const Vec3r& from, const Vec3r& to, Real clearance, Vec3r& exit, Vec3r& normal) const override;
  TriangleMesh surfaceMesh() const override;
  void bounds(Vec3r& lo, Vec3r& hi) const override;

  bool moves() const override { return true; }
  /// The surface's velocity at the surface point nearest x.
  Vec3r velocityAt(const Vec3r& x) const override;
  double maxSurfaceSpeed() const override { return mSpeed; }
  double maxMotionSpeed() const override { return mMaxSpeed; }
  Deformation deformation() const override;
  void sampleDeformation(Real maxGap, std::vector<Vec3r>& start, std::vector<Vec3r>& end) const override;

  /// Moves the surface to time t; the surface before is kept for penetrated().
  void moveTo(double t);
  /// Moves to time t with no step before it (start, restore).
  void resetTo(double t);
  double time() const { return mTime; }

  const MeshSequence& sequence() const { return mSequence; }
  /// The mesh at the current time (world).
  const MeshBoundary& current() const { return *mCurrent; }
  /// Its vertices before the last step (empty after resetTo()).
  const std::vector<Eigen::Vector3f>& previousVertices() const { return mPreviousVertices; }
  /// Points for contacts with rigid bodies: the surface of the interval's first frame
  /// sampled contactPointGap() apart, as vertex weights (made when first asked in an
  /// interval; not thread-safe, asked by the serial contact pass).
  const std::vector<SurfacePoint>& contactPoints() const;

private:
  /// True if interval k is before the first frame or after the last (a frame holds).
  bool holdsIn(long k) const;
  /// Interval k (frames k and k + 1) and weight at time t.
  void intervalAt(double t, long& k, double& weight) const;
  std::vector<Eigen::Vector3f> verticesAt(long k, double weight) const;
  Vec3d velocityOfPoint(long triangle, const Vec3d& point) const;

  MeshSequence mSequence;
  double mTime = 0;
  long mInterval = 0;
  double mWeight = 0;
  std::unique_ptr<MeshBoundary> mCurrent;          ///< the surface now (grids built per frame interval)
  std::vector<Eigen::Vector3f> mPreviousVertices;  ///< before the last step (none after resetTo)
  std::vector<Vec3d> mVertexVelocity;  ///< this interval's, per vertex
  mutable std::vector<SurfacePoint> mContactPoints;
  mutable long mContactInterval = std::numeric_limits<long>::min();
  double mSpeed = 0, mMaxSpeed = 0;
  double mStepReach = 0;  ///< farthest a vertex moved in the last step, m
};

} // namespace cascade
