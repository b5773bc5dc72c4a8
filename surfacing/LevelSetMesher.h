/// @file LevelSetMesher.h
/// @brief The zero iso-surface of a level set as a triangle mesh. Adaptivity 0:
///        our own dual contouring mesher (DualContourMesher.h, Nielson 2004; the
///        same mesh as OpenVDB's volumeToMesh at adaptivity 0, several times
///        faster), outward oriented. Adaptivity > 0: OpenVDB tools::volumeToMesh
///        (dual contouring with sharp-feature aware adaptivity, Museth et al.),
///        quads split along their shorter diagonal, the library's orientation
///        (MeshCleanup makes it outward). Vertices are shared. Internal to
///        surfacing (includes OpenVDB).
#pragma once

#include "libsph/io/TriangleMesh.h"

#include <openvdb/openvdb.h>

namespace cascade::surfacing {

/// `adaptivity` in [0, 1]: 0 gives a uniform mesh, 1 merges flat regions the most.
TriangleMesh levelSetToMesh(const openvdb::FloatGrid& grid, double adaptivity);

} // namespace cascade::surfacing
