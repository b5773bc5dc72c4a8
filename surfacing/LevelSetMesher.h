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
///        thin spike), has the cells of its corners (the merged regions that made
///        it) meshed again unmerged (OpenVDB's adaptivity mask), up to four rounds,
///        else the uniform mesh. The uniform
///        mesh's small components (droplets, spray) are never merged, so the
///        clean-up's volume threshold keeps the same specks in both. A mesh merged
///        less than kMinimumAdaptiveCut times is not worth it: the uniform mesh, and
///        where estimatedAdaptiveCut says so, before the adaptive meshing is paid for.
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

/// An upper bound on how many times fewer vertices (so, about, triangles) VolumeToMesh
/// at `adaptivity` would give than `uniform`, the mesh of `grid` at adaptivity 0, found
/// without meshing: the library's merging test (MergeVoxelRegions: blocks of 2, 4, 8
/// cells whose normals pairwise satisfy 1 - n_i . n_j <= adaptivity, and whose parts
/// all merged) replayed on the uniform mesh's cells. Exact over all blocks up to 2^18
/// vertices; above, over every k-th run of 1,024 vertices (about 2^18 in all). Below
/// kMinimumAdaptiveCut, levelSetToMesh gives the uniform mesh without adaptive meshing.
double estimatedAdaptiveCut(const TriangleMesh& uniform, const openvdb::FloatGrid& grid, double adaptivity);

} // namespace cascade::surfacing
