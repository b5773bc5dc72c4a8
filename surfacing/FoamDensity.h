/// @file FoamDensity.h
/// @brief A fog grid of whitewater foam for volume rendering: the foam
///        particles (OUT/whitewater, type 1) splatted with Zhu & Bridson's
///        k(s) = (1 - s^2)^3 over R = one fluid spacing, normalised so that the
///        value is foam particles per spacing^3 (a uniform cloud of n particles
///        per spacing^3 reads n). Active where it is above zero; class
///        GRID_FOG_VOLUME, world-aligned lattice (voxel centres at integer
///        multiples of the voxel size), so it matches the level set's.
/// Internal to surfacing (includes OpenVDB).
#pragma once

#include "libsph/Types.h"

#include <openvdb/openvdb.h>

#include <vector>

namespace cascade::surfacing {

openvdb::FloatGrid::Ptr foamDensityGrid(const std::vector<Vec3r>& foam, double spacing, double voxelSize);

} // namespace cascade::surfacing
