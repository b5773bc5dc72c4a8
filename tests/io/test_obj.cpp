#include "TestTempDir.h"
#include "libsph/Errors.h"
#include "libsph/io/TriangleMesh.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>

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

TEST(Obj, FloatsOfEveryMagnitudeReadBackBitIdentical) {
  // Random bit patterns over all finite exponents, and the edges of the writer's
  // plain and exponent notations, through the file and back.
  const fs::path path = cascade::test::freshTempDir("obj") / "obj_floats.obj";
  std::vector<float> values = {0.0f, -0.0f, 1.0f, -1.0f, 1e-5f, 9.99999975e-6f, 1e-6f, 999999999.0f, 1e9f, 1e10f,
                               99999.99f, 0.1f, 0.3f, 1.0f / 3.0f, 2.5f, 123456789.0f, 16777216.0f, 16777215.0f,
                               std::numeric_limits<float>::min(), std::numeric_limits<float>::denorm_min(),
                               std::numeric_limits<float>::max(), std::numeric_limits<float>::lowest(),
                               std::numeric_limits<float>::epsilon()};
  for (int k = -45; k <= 38; ++k) {  // powers of ten and their float neighbours
    const float power = std::pow(10.0f, float(k));
    values.push_back(power);
    values.push_back(std::nextafter(power, 0.0f));
    values.push_back(std::nextafter(power, std::numeric_limits<float>::infinity()));
  }
  std::mt19937 random(5);
  while (values.size() < 30000) {
    const std::uint32_t bits = std::uint32_t(random());
    float value;
    std::memcpy(&value, &bits, sizeof value);
    if (std::isfinite(value)) values.push_back(value);
  }
  while (values.size() % 9) values.push_back(0.5f);  // whole triangles: every vertex keeps its file normal
  TriangleMesh mesh;
  for (std::size_t i = 0; i < values.size(); i += 3) {
    mesh.vertices.emplace_back(values[i], values[i + 1], values[i + 2]);
    mesh.normals.emplace_back(values[i + 2], values[i], values[i + 1]);
  }
  for (std::uint32_t v = 0; v + 2 < mesh.vertices.size(); v += 3) mesh.triangles.push_back({v, v + 1, v + 2});
  writeObj(path, mesh);
  const TriangleMesh read = readObj(path);
  ASSERT_EQ(read.vertices.size(), mesh.vertices.size());
  ASSERT_EQ(read.normals.size(), mesh.normals.size());
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    ASSERT_EQ(std::memcmp(read.vertices[v].data(), mesh.vertices[v].data(), 3 * sizeof(float)), 0)
        << "vertex " << v << ": " << mesh.vertices[v].transpose();
    ASSERT_EQ(std::memcmp(read.normals[v].data(), mesh.normals[v].data(), 3 * sizeof(float)), 0)
        << "normal " << v << ": " << mesh.normals[v].transpose();
  }
  EXPECT_EQ(read.triangles, mesh.triangles);
  fs::remove(path);
}

TEST(Obj, WritesNineDigitPlainAndExponentNumbersAndFaceIndices) {
  // The exact text: 9 significant digits of the float's value, trailing zeros dropped,
  // plain for 1e-5 <= |x| < 1e9; faces "v//vn" with 1-based indices.
  const fs::path path = cascade::test::freshTempDir("obj") / "obj_text.obj";
  TriangleMesh mesh;
  mesh.vertices = {{0.5f, 123.25f, -2.0f}, {1e9f, 1.0f / 3.0f, 0.0000305175781f}, {1e-7f, 12345678.0f, 0.1f}};
  mesh.normals = {{0, 0, 1}, {0, -1, 0}, {1, 0, 0}};
  mesh.triangles = {{0, 1, 2}};
  writeObj(path, mesh);
  std::ifstream in(path);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string body = text.substr(text.find("\nv ") + 1);
  EXPECT_EQ(body,
            "v 0.5 123.25 -2\n"
            "v 1e+09 0.333333343 0.0000305175781\n"
            "v 1.00000001e-07 12345678 0.100000001\n"
            "vn 0 0 1\n"
            "vn 0 -1 0\n"
            "vn 1 0 0\n"
            "f 1//1 2//2 3//3\n");
  fs::remove(path);
}
