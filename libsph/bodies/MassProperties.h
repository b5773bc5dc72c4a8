/// @file MassProperties.h
/// @brief The mass properties of a rigid solid from its surface: volume, mass,
///        centre of mass and inertia tensor of the region a closed,
///        outward-oriented triangle mesh bounds, at uniform density.
///
/// The volume integrals of 1, x, y, z, x^2, y^2, z^2, xy, yz and zx are turned
/// into surface integrals by the divergence theorem and summed exactly over the
/// triangles (Mirtich 1996, "Fast and accurate computation of polyhedral mass
/// properties"; in the form of Eberly, "Polyhedral mass properties
/// (revisited)", Geometric Tools 2002). The integrals are taken about the mean
/// of the vertices, not the world origin, and accumulated in double, so a body
/// far from the origin loses no accuracy.
#pragma once

#include "libsph/Types.h"
#include "libsph/bodies/RigidPose.h"
#include "libsph/io/TriangleMesh.h"

#include <string>

namespace cascade {

/// Mass properties of the solid a closed, outward-oriented triangle mesh bounds, at uniform density
/// (Mirtich 1996 / Eberly "Polyhedral mass properties": volume integrals by the divergence theorem over
/// the triangles). All in double precision.
struct MassProperties {
  double volume = 0;                          ///< m^3 (positive for an outward-oriented closed mesh)
  double mass = 0;                            ///< kg
  Vec3d centerOfMass = Vec3d::Zero();         ///< m
  Mat3d inertia = Mat3d::Zero();              ///< inertia tensor about the centre of mass, world axes, kg m^2
};

/// For `mesh` (vertices in world coordinates) at `density` kg/m^3. Throws InputError(context + ": ...") if the
/// enclosed volume is not positive (open or inward-facing mesh).
///
/// In detail, InputError if: the mesh has no triangles, a triangle index is out of range, a vertex is not
/// finite, `density` is not positive and finite, the mesh is not closed (after merging vertices at exactly
/// equal positions, some edge is not matched by the same edge traversed the other way: a hole, or
/// inconsistently oriented triangles), or the signed volume is not positive (inward-facing, or flat).
/// Normals and groups are ignored.
MassProperties massPropertiesOfMesh(const TriangleMesh& mesh, double density, const std::string& context);

/// The same properties scaled to a total mass (density = mass / volume): mass and inertia scale by
/// mass / properties.mass; volume and centre of mass are kept. Requires properties.mass > 0 (as
/// massPropertiesOfMesh returns) and `mass` positive and finite; throws std::invalid_argument otherwise.
MassProperties withMass(const MassProperties& properties, double mass);

} // namespace cascade
