// Meshes as PLY (TriangleMesh.h: writePly, readPly): our reader gives back what
// the writer wrote, bit for bit; assimp's PLY importer (independent of both)
// reads the same vertices, normals and faces; other tools' PLY (ascii, quads,
// other property types) reads too; broken files are named.
#include "TestTempDir.h"
#include "libsph/Errors.h"
#include "libsph/io/Ply.h"
#include "libsph/io/TriangleMesh.h"

#include <assimp/Importer.hpp>
#include <assimp/mesh.h>
#include <assimp/scene.h>
#include <gtest/gtest.h>

#include <fstream>
#include <random>

using namespace cascade;
namespace fs = std::filesystem;

namespace {

/// A closed mesh of `n` x `n` x 2 quads' worth of triangles (a flattened box),
/// with random vertex jitter, normals and velocities.
TriangleMesh randomMesh(int n) {
  TriangleMesh mesh;
  std::mt19937 random(7);
  std::uniform_real_distribution<float> jitter(-0.01f, 0.01f), speed(-3.0f, 3.0f);
  for (int side = 0; side < 2; ++side)
    for (int i = 0; i <= n; ++i)
      for (int j = 0; j <= n; ++j)
        mesh.vertices.emplace_back(float(i) / n + jitter(random), float(j) / n + jitter(random),
                                   0.25f * float(side) + jitter(random));
  const auto index = [n](int side, int i, int j) { return std::uint32_t(side * (n + 1) * (n + 1) + i * (n + 1) + j); };
  for (int side = 0; side < 2; ++side)
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        mesh.triangles.push_back({index(side, i, j), index(side, i + 1, j), index(side, i + 1, j + 1)});
        mesh.triangles.push_back({index(side, i, j), index(side, i + 1, j + 1), index(side, i, j + 1)});
      }
  mesh.computeNormals();
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v)
    mesh.velocities.emplace_back(speed(random), speed(random), speed(random));
  return mesh;
}

} // namespace

TEST(MeshPly, RoundTripKeepsVerticesNormalsVelocitiesAndFaces) {
  const fs::path dir = test::freshTempDir("mesh_ply");
  const TriangleMesh mesh = randomMesh(40);
  writePly(dir / "mesh.ply", mesh, "up: z (scene coordinates)\nsecond line");
  std::vector<std::string> comments;
  const TriangleMesh back = readPly(dir / "mesh.ply", &comments);
  EXPECT_EQ(back.vertices, mesh.vertices);
  EXPECT_EQ(back.normals, mesh.normals);
  EXPECT_EQ(back.velocities, mesh.velocities);
  EXPECT_EQ(back.triangles, mesh.triangles);
  ASSERT_EQ(comments.size(), 4u);  // "Cascade surface mesh", ours, then "written by cascade ..."
  EXPECT_EQ(comments[1], "up: z (scene coordinates)");
  // Binary: 36 bytes per vertex (9 floats) and 13 per triangle, plus the header.
  const auto size = fs::file_size(dir / "mesh.ply");
  EXPECT_GT(size, 36 * mesh.vertices.size() + 13 * mesh.triangles.size());
  EXPECT_LT(size, 36 * mesh.vertices.size() + 13 * mesh.triangles.size() + 600);
}

TEST(MeshPly, AxesTurnPositionsNormalsAndVelocities) {
  const fs::path dir = test::freshTempDir("mesh_ply_axes");
  const TriangleMesh mesh = randomMesh(3);
  writePly(dir / "yup.ply", mesh, "up: y", MeshAxes::ZUpToYUp);
  const TriangleMesh back = readPly(dir / "yup.ply");
  ASSERT_EQ(back.vertices.size(), mesh.vertices.size());
  auto turned = [](const Eigen::Vector3f& v) { return Eigen::Vector3f(v.x(), v.z(), -v.y()); };
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    EXPECT_EQ(back.vertices[v], turned(mesh.vertices[v]));
    EXPECT_EQ(back.normals[v], turned(mesh.normals[v]));
    EXPECT_EQ(back.velocities[v], turned(mesh.velocities[v]));
  }
}

TEST(MeshPly, AssimpReadsTheSameVerticesNormalsAndFaces) {
  const fs::path dir = test::freshTempDir("mesh_ply_assimp");
  const TriangleMesh mesh = randomMesh(20);
  writePly(dir / "mesh.ply", mesh);
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile((dir / "mesh.ply").string(), 0);  // no post-processing
  ASSERT_TRUE(scene) << importer.GetErrorString();
  ASSERT_EQ(scene->mNumMeshes, 1u);
  const aiMesh& read = *scene->mMeshes[0];
  ASSERT_EQ(read.mNumFaces, mesh.triangles.size());
  ASSERT_TRUE(read.HasNormals());
  // assimp may lay the vertices out per face corner: compare through the faces.
  for (unsigned f = 0; f < read.mNumFaces; ++f) {
    ASSERT_EQ(read.mFaces[f].mNumIndices, 3u);
    for (unsigned k = 0; k < 3; ++k) {
      const unsigned corner = read.mFaces[f].mIndices[k];
      const std::uint32_t ours = mesh.triangles[f][k];
      ASSERT_EQ(Eigen::Vector3f(read.mVertices[corner].x, read.mVertices[corner].y, read.mVertices[corner].z),
                mesh.vertices[ours]) << "face " << f << " corner " << k;
      ASSERT_EQ(Eigen::Vector3f(read.mNormals[corner].x, read.mNormals[corner].y, read.mNormals[corner].z),
                mesh.normals[ours]);
    }
  }
}

TEST(MeshPly, ReadsOtherToolsAsciiPolygonsAndTypes) {
  const fs::path dir = test::freshTempDir("mesh_ply_other");
  {
    std::ofstream out(dir / "quad.ply");
    out << "ply\nformat ascii 1.0\ncomment made by hand\nelement vertex 5\nproperty double x\nproperty double y\n"
           "property double z\nproperty uchar red\nelement face 2\nproperty list uchar int vertex_index\n"
           "property int flags\nend_header\n"
           "0 0 0 255\n1 0 0 0\n1 1 0 0\n0 1 0 0\n0.5 0.5 1 0\n"
           "4 0 1 2 3 7\n3 0 1 4 9\n";
  }
  const TriangleMesh mesh = readMesh(dir / "quad.ply");
  ASSERT_EQ(mesh.vertices.size(), 5u);
  EXPECT_TRUE(mesh.normals.empty());
  EXPECT_TRUE(mesh.velocities.empty());
  // The quad is fanned from its first corner.
  const std::vector<std::array<std::uint32_t, 3>> expected = {{0, 1, 2}, {0, 2, 3}, {0, 1, 4}};
  EXPECT_EQ(mesh.triangles, expected);
  EXPECT_EQ(mesh.vertices[4], Eigen::Vector3f(0.5f, 0.5f, 1.0f));
}

TEST(MeshPly, AHeaderOnlyReaderSeesTheElementsAndComments) {
  const fs::path dir = test::freshTempDir("mesh_ply_header");
  const TriangleMesh mesh = randomMesh(40);
  writePly(dir / "mesh.ply", mesh, "up: y");
  const PlyReader header(dir / "mesh.ply", true);
  ASSERT_EQ(header.elements().size(), 2u);
  EXPECT_EQ(header.elements()[0].name, "vertex");
  EXPECT_EQ(header.elements()[0].count, mesh.vertices.size());
  EXPECT_EQ(header.elements()[1].name, "face");
  EXPECT_EQ(header.elements()[1].count, mesh.triangles.size());
  ASSERT_EQ(header.comments().size(), 3u);
  EXPECT_EQ(header.comments()[1], "up: y");
  std::ofstream(dir / "text.ply") << "this is not a PLY file\n";
  EXPECT_THROW(PlyReader(dir / "text.ply", true), InputError);
}

TEST(MeshPly, BrokenFilesAreNamed) {
  const fs::path dir = test::freshTempDir("mesh_ply_broken");
  writePly(dir / "good.ply", randomMesh(4));
  fs::copy_file(dir / "good.ply", dir / "short.ply");
  fs::resize_file(dir / "short.ply", fs::file_size(dir / "good.ply") - 20);
  std::ofstream(dir / "text.ply") << "this is not a PLY file\n";
  std::ofstream(dir / "index.ply") << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                      "property float z\nelement face 1\nproperty list uchar uint vertex_indices\n"
                                      "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n";
  std::ofstream(dir / "big.ply") << "ply\nformat binary_big_endian 1.0\nelement vertex 0\nproperty float x\nend_header\n";
  for (const char* name : {"short.ply", "text.ply", "index.ply", "big.ply", "missing.ply"}) {
    try {
      readPly(dir / name);
      ADD_FAILURE() << name << " was read";
    } catch (const InputError& error) {
      EXPECT_NE(std::string(error.what()).find(name), std::string::npos) << error.what();
    }
  }
  EXPECT_THROW(readMesh(dir / "mesh.stl"), InputError);
}
