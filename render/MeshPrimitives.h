/// @file MeshPrimitives.h
/// @brief Closed triangle meshes of known shape for render tests and the
///        render benchmark: an icosphere (subdivided icosahedron, vertices
///        projected onto the sphere), a latitude-longitude sphere with an
///        optional wavy radius (a splash-like blob of a chosen size), and a box.
///        All wind counter-clockwise seen from outside and carry outward normals.
#pragma once

#include "libsph/io/TriangleMesh.h"

#include <Eigen/Core>

#include <string>

namespace cascade::render {

/// Icosahedron subdivided `subdivisions` times: 20 * 4^subdivisions triangles.
TriangleMesh makeIcosphere(const Eigen::Vector3f& center, float radius, int subdivisions);

/// Sphere of `rings` latitude bands and `segments` longitudes
/// (2 * segments * (rings - 1) triangles). `waviness` > 0 modulates the radius
/// by a sum of low-order spherical waves of that relative amplitude.
TriangleMesh makeLatLongSphere(const Eigen::Vector3f& center, float radius, int rings, int segments,
                               float waviness = 0.0f);

/// Axis-aligned box, 12 triangles, flat normals (24 vertices), one group `name`.
TriangleMesh makeBox(const Eigen::Vector3f& min, const Eigen::Vector3f& max, const std::string& name = "box");

/// Appends `source` to `target`, offsetting indices and groups (no OBJ code needed).
void appendMesh(TriangleMesh& target, const TriangleMesh& source);

} // namespace cascade::render
