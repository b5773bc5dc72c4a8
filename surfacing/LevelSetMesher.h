/// @file LevelSetMesher.h
/// @brief The zero iso-surface of a level set as a triangle mesh: OpenVDB
///        tools::volumeToMesh (dual contouring with sharp-feature aware
///        adaptivity, Museth et al.), quads split along their shorter diagonal.
///        Vertices are shared; orientation is the library's (MeshCleanup makes
///        it outward). Internal to surfacing (includes OpenVDB).
#pragma once

#include "libsph/io/TriangleMesh.h"

#include <openvdb/openvdb.h>

namespace cascade::surfacing {

/// `adaptivity` in [0, 1]: 0 gives a uniform mesh, 1 merges flat regions the most.
TriangleMesh levelSetToMesh(const openvdb::FloatGrid& grid, double adaptivity);

} // namespace cascade::surfacing
