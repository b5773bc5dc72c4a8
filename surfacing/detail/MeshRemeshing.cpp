#include "surfacing/detail/MeshRemeshing.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>

#include <array>
#include <vector>

namespace cascade::surfacing::detail {

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using CgalMesh = CGAL::Surface_mesh<Kernel::Point_3>;

CgalMesh toCgal(const TriangleMesh& mesh) {
  CgalMesh out;
  out.reserve(CgalMesh::size_type(mesh.vertices.size()), CgalMesh::size_type(3 * mesh.triangles.size() / 2),
              CgalMesh::size_type(mesh.triangles.size()));
  std::vector<CgalMesh::Vertex_index> vertex;
  vertex.reserve(mesh.vertices.size());
  for (const auto& p : mesh.vertices) vertex.push_back(out.add_vertex(Kernel::Point_3(p.x(), p.y(), p.z())));
  for (const auto& t : mesh.triangles) out.add_face(vertex[t[0]], vertex[t[1]], vertex[t[2]]);  // rejects non-manifold
  return out;
}

TriangleMesh fromCgal(const CgalMesh& mesh) {
  TriangleMesh out;
  std::vector<std::uint32_t> index(mesh.num_vertices() + mesh.number_of_removed_vertices(), 0);
  for (auto v : mesh.vertices()) {
    index[v.idx()] = std::uint32_t(out.vertices.size());
    const auto& p = mesh.point(v);
    out.vertices.emplace_back(float(p.x()), float(p.y()), float(p.z()));
  }
  for (auto f : mesh.faces()) {
    std::array<std::uint32_t, 3> t{};
    int k = 0;
    for (auto v : CGAL::vertices_around_face(mesh.halfedge(f), mesh))
      if (k < 3) t[k++] = index[v.idx()];
    if (k == 3) out.triangles.push_back(t);
  }
  return out;
}

} // namespace

bool remeshAndDecimate(TriangleMesh& mesh, double remeshEdgeLength, std::size_t triangleBudget) {
  const bool decimate = triangleBudget > 0 && mesh.triangles.size() > triangleBudget;
  if ((remeshEdgeLength <= 0 && !decimate) || mesh.triangles.empty()) return false;
  CgalMesh cgalMesh = toCgal(mesh);
  if (remeshEdgeLength > 0)
    CGAL::Polygon_mesh_processing::isotropic_remeshing(faces(cgalMesh), remeshEdgeLength, cgalMesh);
  if (triangleBudget > 0 && cgalMesh.number_of_faces() > triangleBudget) {
    namespace SMS = CGAL::Surface_mesh_simplification;
    // Stops below a number of edges; a closed triangle mesh has 3/2 edges per face.
    SMS::Count_stop_predicate<CgalMesh> stop(triangleBudget * 3 / 2);
    SMS::edge_collapse(cgalMesh, stop);
  }
  cgalMesh.collect_garbage();
  mesh = fromCgal(cgalMesh);
  return true;
}

} // namespace cascade::surfacing::detail
