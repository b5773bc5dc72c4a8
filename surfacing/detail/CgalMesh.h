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
/// out. `triangleOf` (if given) receives, for each face index, its triangle's index.
inline CgalMesh toCgal(const TriangleMesh& mesh, std::vector<std::size_t>* triangleOf = nullptr) {
  CgalMesh out;
  out.reserve(CgalMesh::size_type(mesh.vertices.size()), CgalMesh::size_type(3 * mesh.triangles.size() / 2),
              CgalMesh::size_type(mesh.triangles.size()));
  std::vector<CgalMesh::Vertex_index> vertex;
  vertex.reserve(mesh.vertices.size());
  for (const auto& p : mesh.vertices) vertex.push_back(out.add_vertex(CgalKernel::Point_3(p.x(), p.y(), p.z())));
  if (triangleOf) triangleOf->clear();
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& corner = mesh.triangles[t];
    if (out.add_face(vertex[corner[0]], vertex[corner[1]], vertex[corner[2]]) != CgalMesh::null_face() && triangleOf)
      triangleOf->push_back(t);
  }
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
