/// @file CgalMesh.h
/// @brief TriangleMesh <-> CGAL::Surface_mesh (EPICK kernel), for the CGAL steps
///        of surfacing (MeshRemeshing.cpp, MeshChecks.cpp: the files compiled
///        with CGAL's -frounding-math). Internal to surfacing.
#pragma once

#include "libsph/io/TriangleMesh.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>

#include <array>
#include <vector>

namespace cascade::surfacing::detail {

using CgalKernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using CgalMesh = CGAL::Surface_mesh<CgalKernel::Point_3>;

/// The mesh as a Surface_mesh; a face that would make it non-manifold is left
/// out and counted in `rejected` (if given).
inline CgalMesh toCgal(const TriangleMesh& mesh, std::size_t* rejected = nullptr) {
  CgalMesh out;
  out.reserve(CgalMesh::size_type(mesh.vertices.size()), CgalMesh::size_type(3 * mesh.triangles.size() / 2),
              CgalMesh::size_type(mesh.triangles.size()));
  std::vector<CgalMesh::Vertex_index> vertex;
  vertex.reserve(mesh.vertices.size());
  for (const auto& p : mesh.vertices) vertex.push_back(out.add_vertex(CgalKernel::Point_3(p.x(), p.y(), p.z())));
  std::size_t refused = 0;
  for (const auto& t : mesh.triangles)
    if (out.add_face(vertex[t[0]], vertex[t[1]], vertex[t[2]]) == CgalMesh::null_face()) ++refused;
  if (rejected) *rejected = refused;
  return out;
}

inline TriangleMesh fromCgal(const CgalMesh& mesh) {
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

} // namespace cascade::surfacing::detail
