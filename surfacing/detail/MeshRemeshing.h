/// @file MeshRemeshing.h
/// @brief The CGAL steps of the mesh clean-up (MeshCleanup.h step 4), kept in a
///        file of their own: CGAL needs -frounding-math, which the rest of
///        surfacing is compiled without (it blocks vectorisation).
///   - isotropic remeshing to a target edge length
///     (CGAL::Polygon_mesh_processing::isotropic_remeshing, Botsch & Kobbelt 2004);
///   - decimation by edge collapse to a triangle budget
///     (Surface_mesh_simplification, Lindstrom & Turk 1998).
/// Internal to surfacing.
#pragma once

#include "libsph/io/TriangleMesh.h"

#include <cstddef>

namespace cascade::surfacing::detail {

/// Remeshes `mesh` (edge length > 0) and/or decimates it to at most `triangleBudget`
/// triangles (> 0), in place. Returns whether it did either (then the normals are
/// gone; the caller recomputes them); false leaves the mesh untouched.
bool remeshAndDecimate(TriangleMesh& mesh, double remeshEdgeLength, std::size_t triangleBudget);

} // namespace cascade::surfacing::detail
