/// @file LevelSetMesher.h
/// @brief The zero iso-surface of a level set as a triangle mesh. Adaptivity 0:
///        our own dual contouring mesher (DualContourMesher.h, Nielson 2004; the
///        same mesh as OpenVDB's volumeToMesh at adaptivity 0, several times
///        faster), outward oriented. Adaptivity > 0: OpenVDB tools::VolumeToMesh
///        (dual contouring that merges cells where the surface is flat, Museth
///        et al.), quads split along their shorter diagonal, the library's
///        orientation (MeshCleanup makes it outward), with an error bound the
///        library does not give: a triangle whose centroid or corner lies more
///        than kAdaptiveTolerance voxels from the zero crossing (|phi| there), or
///        that crosses another triangle (CGAL, MeshChecks.h, over the merged
///        triangles and those around them only), or a vertex of the uniform mesh
///        that lies further than that from the adaptive one (merging that spans a
///        thin spike), has the voxels around it meshed again unmerged (OpenVDB's
///        adaptivity mask), up to three rounds, else the uniform mesh. The uniform
///        mesh's small components (droplets, spray) are never merged, so the
///        clean-up's volume threshold keeps the same specks in both. A mesh merged
///        less than kMinimumAdaptiveCut times is not worth it: the uniform mesh.
///        Vertices are shared. Internal to surfacing (includes OpenVDB).
#pragma once

#include "libsph/io/TriangleMesh.h"

#include <openvdb/openvdb.h>

namespace cascade::surfacing {

/// Largest distance (voxels) of an adaptive mesh's triangle centroids and corners
/// from the level set's zero crossing.
constexpr double kAdaptiveTolerance = 0.45;

/// Adaptive meshing keeps the uniform mesh unless it has this many times fewer triangles.
constexpr double kMinimumAdaptiveCut = 1.5;

/// `adaptivity` in [0, 1]: 0 gives a uniform mesh, 1 merges flat regions the most.
TriangleMesh levelSetToMesh(const openvdb::FloatGrid& grid, double adaptivity);

} // namespace cascade::surfacing
