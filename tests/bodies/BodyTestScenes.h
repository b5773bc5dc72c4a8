/// @file BodyTestScenes.h
/// @brief Scenes shared by the moving-solid tests: box meshes and a floating
///        cube in a resting tank.
#pragma once

#include "libsph/bodies/MassProperties.h"
#include "libsph/bodies/MovingBoundary.h"
#include "libsph/boundary/BoxBoundary.h"
#include "libsph/boundary/MeshBoundary.h"
#include "libsph/solver/Simulation.h"

#include <memory>
#include <string>

namespace cascade::test {

/// The closed box [lo, hi] as 12 outward (counter-clockwise seen from outside) triangles.
inline TriangleMesh boxMesh(const Vec3r& lo, const Vec3r& hi) {
  TriangleMesh mesh;
  for (int k = 0; k < 8; ++k)
    mesh.vertices.emplace_back(float((k & 1) ? hi.x() : lo.x()), float((k & 2) ? hi.y() : lo.y()),
                               float((k & 4) ? hi.z() : lo.z()));
  // corners: bit 0 x, bit 1 y, bit 2 z
  const std::uint32_t faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : faces) {
    mesh.triangles.push_back({f[0], f[1], f[2]});
    mesh.triangles.push_back({f[0], f[2], f[3]});
  }
  return mesh;
}

inline std::unique_ptr<MeshBoundary> boxObstacle(const Vec3r& lo, const Vec3r& hi, const std::string& name) {
  auto mesh = MeshBoundary::fromMesh(boxMesh(lo, hi), name);
  mesh->setName(name);
  return mesh;
}

/// A rigid cube of edge `edge` at `density` with its lower face's centre at `bottom`.
inline std::unique_ptr<MovingBoundary> floatingCube(const Vec3r& bottom, Real edge, double density,
                                                    const std::string& name = "cube") {
  const Vec3r half(edge / 2, edge / 2, 0);
  auto mesh = boxObstacle(bottom - half, bottom + half + Vec3r(0, 0, edge), name);
  const MassProperties properties = massPropertiesOfMesh(mesh->mesh(), density, name);
  return std::make_unique<MovingBoundary>(std::move(mesh), RigidBody(properties, 0.4, 0.0));
}

} // namespace cascade::test
