// surfacing::cleanupMesh on small hand-made meshes: degenerate triangles and
// components below the volume threshold go, unused vertices go, an inward mesh
// is turned outward, normals are unit, outward and area weighted, and the
// result does not depend on the number of threads.
#include "surfacing/MeshCleanup.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

using namespace cascade;
using surfacing::cleanupMesh;
using surfacing::MeshCleanupSettings;

namespace {

/// A unit cube (vertex i at (i & 1, i >> 1 & 1, i >> 2 & 1)), counter-clockwise
/// seen from outside; a 0.1 m corner tetrahedron at (10, 10, 10); a triangle with
/// a repeated vertex on the cube; a zero-area triangle of three collinear
/// vertices of its own; one vertex no triangle uses.
TriangleMesh cubeTetrahedronAndJunk() {
  TriangleMesh mesh;
  for (int i = 0; i < 8; ++i) mesh.vertices.emplace_back(float(i & 1), float(i >> 1 & 1), float(i >> 2 & 1));
  mesh.triangles = {{0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}, {0, 1, 5}, {0, 5, 4},
                    {2, 6, 7}, {2, 7, 3}, {0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}};
  const Eigen::Vector3f p(10, 10, 10);
  for (const Eigen::Vector3f& offset : {Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(0.1f, 0, 0),
                                        Eigen::Vector3f(0, 0.1f, 0), Eigen::Vector3f(0, 0, 0.1f)})
    mesh.vertices.push_back(p + offset);
  mesh.triangles.insert(mesh.triangles.end(), {{8, 10, 9}, {8, 9, 11}, {8, 11, 10}, {9, 10, 11}});
  mesh.triangles.push_back({0, 0, 1});  // repeated vertex
  for (int i = 0; i < 3; ++i) mesh.vertices.emplace_back(float(-5 - i), -5.0f, -5.0f);
  mesh.triangles.push_back({12, 13, 14});  // collinear
  mesh.vertices.emplace_back(7.0f, 7.0f, 7.0f);  // unused
  return mesh;
}

void expectUnitOutwardNormals(const TriangleMesh& mesh, const Eigen::Vector3f& centre) {
  ASSERT_EQ(mesh.normals.size(), mesh.vertices.size());
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    EXPECT_NEAR(mesh.normals[v].norm(), 1.0f, 1e-6f) << "vertex " << v;
    EXPECT_GT(mesh.normals[v].dot(mesh.vertices[v] - centre), 0.0f) << "vertex " << v;
  }
}

} // namespace

TEST(MeshCleanup, DropsDegenerateSmallComponentsAndUnusedVertices) {
  TriangleMesh mesh = cubeTetrahedronAndJunk();
  MeshCleanupSettings settings;
  settings.minComponentVolume = 0.01;  // the tetrahedron holds 1/6000 m^3
  const auto stats = cleanupMesh(mesh, settings);
  EXPECT_EQ(stats.degenerateTriangles, 2u);
  EXPECT_EQ(stats.droppedComponents, 1u);
  EXPECT_EQ(stats.components, 2u);  // cube and tetrahedron (the zero-area triangle encloses nothing)
  EXPECT_FALSE(stats.flipped);
  ASSERT_EQ(mesh.triangles.size(), 12u);
  ASSERT_EQ(mesh.vertices.size(), 8u);
  EXPECT_NEAR(surfacing::meshVolume(mesh), 1.0, 1e-6);
  for (const auto& t : mesh.triangles)
    for (std::uint32_t v : t) EXPECT_LT(v, 8u);
  expectUnitOutwardNormals(mesh, Eigen::Vector3f(0.5f, 0.5f, 0.5f));
  // Area weighted: vertex 0 has one triangle of each of its three faces (areas equal).
  EXPECT_TRUE(mesh.normals[0].isApprox(Eigen::Vector3f(-1, -1, -1).normalized(), 1e-6f));
}

TEST(MeshCleanup, KeepsSmallComponentsWithoutThreshold) {
  TriangleMesh mesh = cubeTetrahedronAndJunk();
  const auto stats = cleanupMesh(mesh, MeshCleanupSettings{});
  EXPECT_EQ(stats.droppedComponents, 0u);
  EXPECT_EQ(mesh.triangles.size(), 16u);
  EXPECT_EQ(mesh.vertices.size(), 12u);
  EXPECT_NEAR(surfacing::meshVolume(mesh), 1.0 + 0.001 / 6, 1e-6);
}

TEST(MeshCleanup, TurnsAnInwardMeshOutward) {
  TriangleMesh mesh = cubeTetrahedronAndJunk();
  for (auto& t : mesh.triangles) std::swap(t[1], t[2]);
  MeshCleanupSettings settings;
  settings.minComponentVolume = 0.01;
  const auto stats = cleanupMesh(mesh, settings);
  EXPECT_TRUE(stats.flipped);
  EXPECT_EQ(stats.droppedComponents, 1u);
  EXPECT_NEAR(surfacing::meshVolume(mesh), 1.0, 1e-6);
  expectUnitOutwardNormals(mesh, Eigen::Vector3f(0.5f, 0.5f, 0.5f));
}

TEST(MeshCleanup, SameResultForOneAndTwoThreads) {
  // Many copies of the cube so that both halves of the triangle list hold work.
  TriangleMesh many;
  for (int copy = 0; copy < 200; ++copy) {
    TriangleMesh cube = cubeTetrahedronAndJunk();
    for (auto& v : cube.vertices) v += Eigen::Vector3f(3.0f * float(copy), 0, 0);
    many.append(cube);
  }
  MeshCleanupSettings settings;
  settings.minComponentVolume = 0.01;
  TriangleMesh one = many, two = many;
  {
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 1);
    cleanupMesh(one, settings);
  }
  {
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 2);
    cleanupMesh(two, settings);
  }
  EXPECT_EQ(one.triangles, two.triangles);
  EXPECT_EQ(one.vertices, two.vertices);
  EXPECT_EQ(one.normals, two.normals);
  EXPECT_EQ(one.triangles.size(), 200u * 12u);
}
