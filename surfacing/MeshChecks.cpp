#include "surfacing/MeshChecks.h"

#include "surfacing/detail/CgalMesh.h"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/boost/graph/helpers.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

namespace cascade::surfacing {

namespace {

using detail::CgalKernel;
using Point = CgalKernel::Point_3;
using Triangle = CgalKernel::Triangle_3;
using TriangleList = std::vector<Triangle>;
using Primitive = CGAL::AABB_triangle_primitive<CgalKernel, TriangleList::const_iterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<CgalKernel, Primitive>>;

Point point(const Eigen::Vector3f& v) { return Point(v.x(), v.y(), v.z()); }

/// A mesh's triangles in a CGAL AABB tree ready for distance queries (the tree refers
/// to the list it holds, so it stays where it was built).
class TriangleTree {
public:
  explicit TriangleTree(const TriangleMesh& mesh) {
    mTriangles.reserve(mesh.triangles.size());
    for (const auto& t : mesh.triangles)
      mTriangles.emplace_back(point(mesh.vertices[t[0]]), point(mesh.vertices[t[1]]), point(mesh.vertices[t[2]]));
    mTree.insert(mTriangles.begin(), mTriangles.end());
    mTree.build();
    mTree.accelerate_distance_queries();
  }
  TriangleTree(const TriangleTree&) = delete;
  TriangleTree& operator=(const TriangleTree&) = delete;
  double squaredDistance(const Point& p) const { return mTree.squared_distance(p); }

private:
  TriangleList mTriangles;
  Tree mTree;
};

/// h(a, b): the largest distance from a's vertices and centroids to b's triangles.
double directedDistance(const TriangleMesh& a, const TriangleMesh& b) {
  if (a.vertices.empty() || b.triangles.empty()) return a.vertices.empty() ? 0.0 : INFINITY;
  const TriangleTree tree(b);
  const std::size_t samples = a.vertices.size() + a.triangles.size();
  const double squared = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, samples, 4096), 0.0,
      [&](const auto& range, double worst) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          Point sample;
          if (i < a.vertices.size()) {
            sample = point(a.vertices[i]);
          } else {
            const auto& t = a.triangles[i - a.vertices.size()];
            sample = point((a.vertices[t[0]] + a.vertices[t[1]] + a.vertices[t[2]]) / 3.0f);
          }
          worst = std::max(worst, tree.squaredDistance(sample));
        }
        return worst;
      },
      [](double x, double y) { return std::max(x, y); });
  return std::sqrt(squared);
}

} // namespace

MeshTopology checkMeshTopology(const TriangleMesh& mesh) {
  MeshTopology result;
  const detail::CgalMesh cgal = detail::toCgal(mesh);
  result.rejectedFaces = mesh.triangles.size() - cgal.number_of_faces();
  result.closed = result.rejectedFaces == 0 && CGAL::is_closed(cgal);
  result.selfIntersecting = CGAL::Polygon_mesh_processing::does_self_intersect(cgal);
  return result;
}

std::vector<std::size_t> selfIntersectingTriangles(const TriangleMesh& mesh) {
  std::vector<std::size_t> triangleOf;  // the triangle of each face
  const detail::CgalMesh cgal = detail::toCgal(mesh, &triangleOf);
  std::vector<std::pair<detail::CgalMesh::Face_index, detail::CgalMesh::Face_index>> pairs;
  CGAL::Polygon_mesh_processing::self_intersections(cgal, std::back_inserter(pairs));
  std::vector<std::size_t> result;
  for (const auto& [first, second] : pairs) {
    result.push_back(triangleOf[first.idx()]);
    result.push_back(triangleOf[second.idx()]);
  }
  std::sort(result.begin(), result.end());
  result.erase(std::unique(result.begin(), result.end()), result.end());
  return result;
}

std::vector<std::size_t> pointsFartherThan(const std::vector<Eigen::Vector3f>& points, const TriangleMesh& mesh,
                                           double distance) {
  if (points.empty()) return {};
  std::vector<std::size_t> all(points.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
  if (mesh.triangles.empty()) return all;
  const TriangleTree tree(mesh);
  std::vector<char> far(points.size(), 0);
  const double squared = distance * distance;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 1024), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) far[i] = tree.squaredDistance(point(points[i])) > squared;
  });
  std::vector<std::size_t> result;
  for (std::size_t i = 0; i < far.size(); ++i)
    if (far[i]) result.push_back(i);
  return result;
}

double hausdorffDistance(const TriangleMesh& a, const TriangleMesh& b) {
  return std::max(directedDistance(a, b), directedDistance(b, a));
}

} // namespace cascade::surfacing
