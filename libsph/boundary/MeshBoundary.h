/// @file MeshBoundary.h
/// @brief A triangle-mesh obstacle (SEED section 2.2): loaded from OBJ, PLY
///        or STL with assimp, placed by a transform (uniform scale, rotation,
///        translation), simplified with CGAL Surface_mesh_simplification to a
///        target triangle count (the SEED takes the bunny from 3,600 to 900),
///        sampled with type I particles: 7 per small triangle (3 vertices, 3
///        edge midpoints, centroid; shared vertices and midpoints once), larger
///        triangles area-true (sampleTriangles()).
///        Type II mirrors are taken across the tangent plane at the closest
///        surface point. Fluid lives outside; the mesh must be closed (small
///        holes, as in the scanned bunny's base, are filled with CGAL's hole
///        filling and logged).
///
/// Inside test: the generalised winding number (Jacobson et al. 2013),
/// which stays right on nearly closed meshes.
#pragma once

#include "libsph/boundary/Boundary.h"

#include <array>
#include <filesystem>
#include <memory>

namespace cascade {

/// How to turn a mesh file into an obstacle.
struct MeshObstacleOptions {
  Transform transform;          ///< local (file) to world
  std::size_t targetTriangles = 0;  ///< simplify to at most this many; 0 = keep all
  bool requireClosed = true;    ///< fill small holes; InputError if still open
};

/// Loads a mesh file with assimp (all meshes of the file merged, vertices
/// welded). Throws InputError naming the file if it does not load or is empty.
TriangleMesh loadMeshFile(const std::filesystem::path& path);

/// Simplifies with CGAL edge collapse (Lindstrom-Turk cost and placement)
/// until at most targetTriangles remain. `context` names the file in errors.
TriangleMesh simplifyMesh(const TriangleMesh& mesh, std::size_t targetTriangles,
                          const std::string& context);

/// Number of edges used by exactly one triangle (0 for a closed mesh).
std::size_t countBorderEdges(const TriangleMesh& mesh);

/// Fills the holes of a mesh with CGAL (triangulate_refine_and_fair_hole);
/// returns the number of holes filled.
std::size_t fillMeshHoles(TriangleMesh& mesh, const std::string& context);

/// Type I samples of a mesh, each point once, none farther than maxGap from any
/// surface point: every vertex, every edge at most maxGap apart (at least its
/// midpoint), the centroid of a small triangle (longest edge <= 2 maxGap: the SEED's
/// 7 points), and rows of points at most maxGap apart inside a larger one (parallel
/// to its longest edge, kept maxGap / 2 off the others), so that the count follows
/// area / maxGap^2 for any triangle shape. `rowSampledTriangles`: the larger ones.
std::vector<Vec3r> sampleTriangles(const TriangleMesh& mesh, Real maxGap,
                                   std::size_t* rowSampledTriangles = nullptr);

/// A point of a mesh's surface as a weighted sum of (up to) three of its vertices, so
/// that it can be found again on the same mesh with its vertices moved (a deforming
/// sequence's next frame).
struct SurfacePoint {
  std::array<std::uint32_t, 3> vertex{0, 0, 0};
  std::array<double, 3> weight{1, 0, 0};

  Vec3d on(const std::vector<Eigen::Vector3f>& positions) const {
    return weight[0] * positions[vertex[0]].cast<double>() + weight[1] * positions[vertex[1]].cast<double>() +
           weight[2] * positions[vertex[2]].cast<double>();
  }
};

/// sampleTriangles()'s samples as surface points, in the same order.
std::vector<SurfacePoint> sampleTrianglePoints(const TriangleMesh& mesh, Real maxGap);

class MeshBoundary final : public Boundary {
public:
  /// Loads, places, simplifies, closes. Logs the triangle counts to `log`
  /// (if not null). Throws InputError naming the file on any failure.
  static std::unique_ptr<MeshBoundary> load(const std::filesystem::path& path,
                                            const MeshObstacleOptions& options,
                                            std::ostream* log = nullptr);
  /// From a mesh already in world coordinates (closed, outward normals). With `slack` > 0
  /// its search grids allow every vertex to move by up to that much (moveVertices()).
  static std::unique_ptr<MeshBoundary> fromMesh(TriangleMesh worldMesh, const std::string& context,
                                                double slack = 0);

  /// Moves the vertices (the same triangles): a deforming mesh between two frames. Within
  /// the slack of fromMesh() of where it was built, the grids are kept (their triangles'
  /// bounds updated); beyond it they are rebuilt. Not during queries.
  void moveVertices(const std::vector<Eigen::Vector3f>& vertices);

  ~MeshBoundary() override;

  std::string kind() const override { return "mesh"; }
  void sampleSurface(Real maxGap, std::vector<Vec3r>& samples) const override;
  void mirrorMaps(const Vec3r& x, Real range, std::uint32_t boundaryIndex,
                  std::vector<MirrorMap>& maps) const override;
  bool isInside(const Vec3r& x) const override;
  bool isInsideNear(const Vec3r& x, Real reach) const override;
  /// The first triangle the move enters through (segment-triangle tests over the
  /// grid cells the move spans; a move through a thin part counts): exit `clearance`
  /// off the entry point along its face normal (`from` if that is inside too). A
  /// move that ended inside without a crossing found (an edge or a vertex hit) is
  /// found by the winding number, taken only for a `to` within |to - from| of the
  /// surface; exit `clearance` off the closest surface point.
  bool penetrated(const Vec3r& from, const Vec3r& to, Real clearance, Vec3r& exit, Vec3r& normal) const override;
  /// Out through the nearest triangle.
  bool escape(const Vec3r& x, Real clearance, Vec3r& exit, Vec3r& normal) const override;
  TriangleMesh surfaceMesh() const override;
  void bounds(Vec3r& lo, Vec3r& hi) const override;

  /// Generalised winding number at x (1 inside, 0 outside a closed mesh).
  double windingNumber(const Vec3r& x) const;
  /// Closest point on the surface within maxDistance; false if none.
  bool closestPoint(const Vec3r& x, Real maxDistance, Vec3r& point, Vec3r& normal) const;
  /// The triangle (index into mesh().triangles) with the closest point within maxDistance
  /// (the lowest index among equals), that point in `point`; -1 if none.
  long closestTriangle(const Vec3d& x, double maxDistance, Vec3d& point) const;

  std::size_t triangleCount() const;
  const TriangleMesh& mesh() const;

private:
  MeshBoundary();
  struct Impl;
  std::unique_ptr<Impl> mImpl;
};

} // namespace cascade
