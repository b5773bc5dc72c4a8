/// @file MeshChecks.h
/// @brief Measures of a surface mesh's quality, with CGAL (for tests and
///        `cascade bench surface`):
///  - checkMeshTopology: whether the mesh is manifold (CGAL::Surface_mesh takes
///    every face), closed (CGAL::is_closed: no border edge) and free of
///    self-intersections (Polygon_mesh_processing::does_self_intersect: no two
///    faces meet but along a shared edge or vertex);
///  - pointsFartherThan: the points further than a distance from a mesh;
///  - hausdorffDistance: the symmetric Hausdorff distance between two meshes,
///    max(h(A, B), h(B, A)) with h(A, B) the largest distance from a point of A
///    to B, over the vertices and triangle centroids of A (an approximation from
///    below, good to the size of a triangle), found in a CGAL AABB tree of B's
///    triangles.
#pragma once

#include "libsph/io/TriangleMesh.h"

#include <cstddef>
#include <vector>

namespace cascade::surfacing {

struct MeshTopology {
  std::size_t rejectedFaces = 0;  ///< faces that would make the mesh non-manifold
  bool closed = false;            ///< manifold with no border edge
  bool selfIntersecting = false;
};

MeshTopology checkMeshTopology(const TriangleMesh& mesh);

/// Indices of the triangles that intersect another triangle of the mesh other
/// than along a shared edge or vertex (PMP::self_intersections), ascending.
std::vector<std::size_t> selfIntersectingTriangles(const TriangleMesh& mesh);

/// Indices of the points further than `distance` from every triangle of `mesh`,
/// ascending (a CGAL AABB tree of its triangles).
std::vector<std::size_t> pointsFartherThan(const std::vector<Eigen::Vector3f>& points, const TriangleMesh& mesh,
                                           double distance);

/// Symmetric Hausdorff distance between `a` and `b` (their units).
double hausdorffDistance(const TriangleMesh& a, const TriangleMesh& b);

} // namespace cascade::surfacing
