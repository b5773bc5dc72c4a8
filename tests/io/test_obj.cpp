#include "TestTempDir.h"
#include "libsph/Errors.h"
#include "libsph/io/TriangleMesh.h"

#include <gtest/gtest.h>

#include <fstream>

using namespace cascade;
namespace fs = std::filesystem;

namespace {
TriangleMesh tetrahedron() {
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  mesh.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  mesh.computeNormals();
  return mesh;
}
} // namespace

TEST(Obj, RoundTripKeepsVerticesNormalsTrianglesAndGroups) {
  const fs::path path = cascade::test::freshTempDir("obj") / "obj_roundtrip.obj";
  TriangleMesh mesh = tetrahedron();
  TriangleMesh second = tetrahedron();
  for (auto& v : second.vertices) v += Eigen::Vector3f(2.5f, -1.0f / 3.0f, 1e-7f);
  mesh.groups = {{"first", 0, 4}};
  second.groups = {{"second", 0, 4}};
  mesh.append(second);
  writeObj(path, mesh);
  const TriangleMesh read = readObj(path);
  EXPECT_EQ(read.vertices, mesh.vertices);  // shortest round-trip float formatting: exact
  EXPECT_EQ(read.normals, mesh.normals);
  EXPECT_EQ(read.triangles, mesh.triangles);
  ASSERT_EQ(read.groups.size(), 2u);
  EXPECT_EQ(read.groups[1].name, "second");
  EXPECT_EQ(read.groups[1].begin, 4u);
  EXPECT_EQ(read.groups[1].end, 8u);
  fs::remove(path);
}

TEST(Obj, NormalsPointOutwardOnAClosedMesh) {
  const TriangleMesh mesh = tetrahedron();
  const Eigen::Vector3f centre(0.25f, 0.25f, 0.25f);
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v)
    EXPECT_GT(mesh.normals[v].dot(mesh.vertices[v] - centre), 0.0f);
}

TEST(Obj, ReadsQuadsNegativeIndicesAndTextureForms) {
  const fs::path path = cascade::test::freshTempDir("obj") / "obj_forms.obj";
  std::ofstream(path) << "# comment\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n"
                         "f 1/1/1 2/1/1 3/1/1 4/1/1\nf -4 -3 -2\n";
  const TriangleMesh mesh = readObj(path);
  ASSERT_EQ(mesh.triangles.size(), 3u);
  EXPECT_EQ(mesh.triangles[1], (std::array<std::uint32_t, 3>{0, 2, 3}));
  EXPECT_EQ(mesh.triangles[2], (std::array<std::uint32_t, 3>{0, 1, 2}));
  ASSERT_EQ(mesh.normals.size(), 4u);
  EXPECT_EQ(mesh.normals[2], Eigen::Vector3f(0, 0, 1));
  fs::remove(path);
}

TEST(Obj, MalformedFilesNameFileAndLine) {
  const fs::path path = cascade::test::freshTempDir("obj") / "obj_bad.obj";
  std::ofstream(path) << "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 7\n";
  try {
    readObj(path);
    ADD_FAILURE() << "bad index accepted";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("/obj_bad.obj:4:"), std::string::npos) << error.what();
  }
  std::ofstream(path) << "v 0 zero 0\n";
  EXPECT_THROW(readObj(path), InputError);
  EXPECT_THROW(readObj(cascade::test::freshTempDir("obj") / "no_such_mesh.obj"), InputError);
  fs::remove(path);
}

TEST(Obj, EmptyMeshRoundTrips) {
  const fs::path path = cascade::test::freshTempDir("obj") / "obj_empty.obj";
  writeObj(path, TriangleMesh{});
  EXPECT_TRUE(readObj(path).empty());
  fs::remove(path);
}
