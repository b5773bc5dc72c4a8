/// @file MeshCleanup.h
/// @brief Clean-up of an extracted iso-surface mesh:
///   1. split into vertex-connected components (union-find);
///   2. one pass over the triangles: drop degenerate ones (a repeated vertex or
///      zero area), sum each component's enclosed volume |V| (divergence theorem,
///      V = sum (a - o).((b - a) x (c - a)) / 6 about a vertex o of the
///      component) and drop components below a threshold (spray specks, tiny
///      bubbles), and sum the area-weighted vertex normals from the same cross
///      products;
///   3. orient outward: the extractor's orientation is consistent, so the whole
///      mesh (and its normals) is flipped if its total signed volume is negative
///      (cavities keep their inward-facing normals, which point out of the fluid);
///      vertices no triangle uses any more are dropped;
///   4. optionally CGAL (detail/MeshRemeshing.h): isotropic remeshing
///      (PMP::isotropic_remeshing, Botsch & Kobbelt 2004) to a target edge length,
///      and/or decimation by edge collapse (Surface_mesh_simplification,
///      Lindstrom-Turk 1998) to a triangle budget; normals again after it.
/// Steps 1-3 run on the indexed mesh directly (CGAL's Surface_mesh construction
/// alone would cost more than the whole surfacing of a frame); CGAL is used where
/// it does the geometry work (4).
#pragma once

#include "libsph/io/TriangleMesh.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace cascade::surfacing {

struct MeshCleanupSettings {
  double minComponentVolume = 0;  ///< m^3
  std::size_t triangleBudget = 0; ///< 0: no decimation
  double remeshEdgeLength = 0;    ///< 0: no remeshing
};

struct MeshCleanupStats {
  std::size_t degenerateTriangles = 0, droppedComponents = 0, components = 0;
  bool flipped = false;
};

/// Cleans `mesh` in place; on return it has outward normals.
MeshCleanupStats cleanupMesh(TriangleMesh& mesh, const MeshCleanupSettings& settings);

/// Signed volume enclosed by a closed, consistently oriented mesh (m^3).
double meshVolume(const TriangleMesh& mesh);

/// The root (smallest vertex index) of each vertex's vertex-connected component.
std::vector<std::uint32_t> componentRoots(const TriangleMesh& mesh);

} // namespace cascade::surfacing
