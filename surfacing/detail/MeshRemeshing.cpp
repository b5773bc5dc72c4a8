#include "surfacing/detail/MeshRemeshing.h"

#include "surfacing/detail/CgalMesh.h"

#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>

namespace cascade::surfacing::detail {

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
