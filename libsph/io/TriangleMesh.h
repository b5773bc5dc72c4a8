/// @file TriangleMesh.h
/// @brief A plain indexed triangle mesh with optional per-vertex normals and
///        velocities and named groups, and its Wavefront OBJ and binary PLY
///        readers and writers. Used for OUT/mesh/fluid.NNNN.obj or .ply
///        (surfacing writes, render and inspect read) and for
///        OUT/geometry/solids.obj (the bake writes the scene's solid geometry
///        in world coordinates, render draws it).
#pragma once

#include "libsph/Types.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace cascade {

struct TriangleMesh {
  std::vector<Eigen::Vector3f> vertices;
  std::vector<Eigen::Vector3f> normals;  ///< per vertex; empty or vertices.size()
  /// Per vertex (m/s, for motion blur); empty or vertices.size().
  std::vector<Eigen::Vector3f> velocities;
  std::vector<std::array<std::uint32_t, 3>> triangles;  ///< counter-clockwise seen from outside

  /// Named ranges of triangles (OBJ "g NAME"): triangles [begin, end).
  struct Group {
    std::string name;
    std::size_t begin = 0, end = 0;
  };
  std::vector<Group> groups;

  bool empty() const { return triangles.empty(); }
  /// Area-weighted per-vertex normals from the triangles.
  void computeNormals();
  /// Appends another mesh (its groups too).
  void append(const TriangleMesh& other);
};

/// How writeObj and writePly map the mesh's coordinates (vertices, normals and
/// velocities) to the file's.
enum class MeshAxes {
  AsIs,      ///< stored as they are
  ZUpToYUp,  ///< a z-up point (x, y, z) stored as (x, z, -y), for y-up importers
};

/// `v` (a point, normal or velocity) in the file's axes.
inline Eigen::Vector3f toFileAxes(const Eigen::Vector3f& v, MeshAxes axes) {
  return axes == MeshAxes::ZUpToYUp ? Eigen::Vector3f(v.x(), v.z(), -v.y()) : v;
}

/// Area of the mesh's triangles (m^2 for a mesh in metres).
double surfaceArea(const TriangleMesh& mesh);

/// For each vertex, the index of the first vertex at exactly its position (its own
/// index if none comes before it): the welding of seams that repeat a position.
std::vector<std::uint32_t> firstVertexAtSamePosition(const std::vector<Eigen::Vector3f>& vertices);

/// The '\n'-separated lines of `text`, each after `prefix` and ended by '\n' (the
/// header comments of OBJ, "# ", and PLY, "comment ").
std::string prefixedLines(const std::string& text, const std::string& prefix);

/// Writes OBJ ("v", "vn", "g", "f a//a b//b c//c"), atomically. Numbers have 9
/// significant digits (trailing zeros dropped): they read back to the same float. Blocks of
/// lines are formatted in parallel (TBB) and written in order, so the file is the
/// same as a serial writer's.
void writeObj(const std::filesystem::path& path, const TriangleMesh& mesh);
/// The same with extra comment lines after the first ("# up: y"; one per '\n'-separated
/// line), and the coordinates mapped by `axes` on the way out.
void writeObj(const std::filesystem::path& path, const TriangleMesh& mesh, const std::string& comment,
              MeshAxes axes = MeshAxes::AsIs);

/// Reads OBJ written by writeObj or another tool (v, vn, g/o, f with any of
/// the index forms, polygons fanned into triangles, negative indices).
/// A missing or malformed file throws InputError naming the file and line.
TriangleMesh readObj(const std::filesystem::path& path);

/// Writes binary little-endian PLY, atomically: vertex properties float x y z,
/// then nx ny nz if the mesh has normals, then vx vy vz if it has velocities;
/// faces as "list uchar uint vertex_indices". `comment` lines (one per '\n'-separated
/// line) go into the header after "comment Cascade surface mesh"; coordinates are
/// mapped by `axes` on the way out. Groups are not written (PLY has none).
void writePly(const std::filesystem::path& path, const TriangleMesh& mesh, const std::string& comment = {},
              MeshAxes axes = MeshAxes::AsIs);

/// Reads a PLY mesh (ascii or binary_little_endian, as writePly or another tool
/// writes it): x y z, and nx ny nz and vx vy vz when all three are present; faces
/// from the face element's vertex_indices (or vertex_index) list, polygons
/// fanned into triangles. `comments`, if given, receives the header comments.
/// A missing or malformed file throws InputError naming the file.
TriangleMesh readPly(const std::filesystem::path& path, std::vector<std::string>* comments = nullptr);

/// readObj or readPly by the file's extension (.obj or .ply); InputError otherwise.
TriangleMesh readMesh(const std::filesystem::path& path);

} // namespace cascade
