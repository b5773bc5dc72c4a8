/// @file ImplicitToLevelSet.h
/// @brief Turns an implicit field sampled in FloatTree leaves (surface where
///        field == iso) into a narrow-band signed distance estimate,
///        phi = (field - iso) / |grad field| (first order: exact for a linear
///        field; the Newton step of Hart 1996, "Sphere tracing"), negative inside.
///        Central differences, one-sided where a neighbour lies outside the
///        rasterized leaves or is undefined (value >= kUndefinedField: no particle
///        near; such voxels are outside). |phi| >= halfWidth voxels becomes an
///        inactive +-background; then pruneLevelSet and signedFloodFill.
/// Internal to surfacing (includes OpenVDB).
#pragma once

#include <openvdb/openvdb.h>

namespace cascade::surfacing::detail {

constexpr float kUndefinedField = 1e30f;

/// `insideAbove`: the inside is field > iso (a density) rather than field < iso (a distance).
openvdb::FloatGrid::Ptr implicitToLevelSet(const openvdb::FloatTree& field, float iso, bool insideAbove,
                                           double voxelSize, int halfWidth);

/// The same, turning `field` itself into the level set (no second tree): the
/// same values and topology.
openvdb::FloatGrid::Ptr implicitToLevelSet(openvdb::FloatTree::Ptr field, float iso, bool insideAbove,
                                           double voxelSize, int halfWidth);

} // namespace cascade::surfacing::detail
