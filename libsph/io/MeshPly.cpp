// Triangle meshes as PLY (TriangleMesh.h: writePly, readPly, readMesh).
#include "libsph/Errors.h"
#include "libsph/Version.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/io/Ply.h"
#include "libsph/io/TriangleMesh.h"

#include <tbb/parallel_for.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>

namespace cascade {

namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "PLY records are written as the machine's little-endian bytes");

/// Records formatted and written per chunk (bounds the buffer at a few MB).
constexpr std::size_t kPlyChunkRecords = std::size_t(1) << 17;

/// Writes `count` records of `size` bytes, each made by fill(record, bytes), in
/// chunks formatted in parallel.
template <class Fill>
bool writeRecords(std::FILE* file, std::size_t count, std::size_t size, const Fill& fill) {
  std::vector<char> buffer(std::min(count, kPlyChunkRecords) * size);
  for (std::size_t begin = 0; begin < count; begin += kPlyChunkRecords) {
    const std::size_t end = std::min(count, begin + kPlyChunkRecords);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(begin, end, 8192), [&](const auto& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i) fill(i, buffer.data() + (i - begin) * size);
    });
    const std::size_t bytes = (end - begin) * size;
    if (std::fwrite(buffer.data(), 1, bytes, file) != bytes) return false;
  }
  return true;
}

} // namespace

void writePly(const std::filesystem::path& path, const TriangleMesh& mesh, const std::string& comment,
              MeshAxes axes) {
  const std::size_t n = mesh.vertices.size();
  const bool withNormals = !mesh.normals.empty() && mesh.normals.size() == n;
  const bool withVelocities = !mesh.velocities.empty() && mesh.velocities.size() == n;
  std::string header = "ply\nformat binary_little_endian 1.0\ncomment Cascade surface mesh\n";
  header += prefixedLines(comment, "comment ");
  header += "comment " + writtenBy() + "\n";
  header += "element vertex " + std::to_string(n) + "\n";
  for (const char* name : {"x", "y", "z"}) header += std::string("property float ") + name + "\n";
  if (withNormals)
    for (const char* name : {"nx", "ny", "nz"}) header += std::string("property float ") + name + "\n";
  if (withVelocities)
    for (const char* name : {"vx", "vy", "vz"}) header += std::string("property float ") + name + "\n";
  header += "element face " + std::to_string(mesh.triangles.size()) +
            "\nproperty list uchar uint vertex_indices\nend_header\n";

  const std::size_t vertexSize = sizeof(float) * (3 + (withNormals ? 3 : 0) + (withVelocities ? 3 : 0));
  constexpr std::size_t faceSize = 1 + 3 * sizeof(std::uint32_t);
  writeFileAtomically(path, [&](const std::filesystem::path& temp) {
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(temp.c_str(), "wb"), &std::fclose);
    if (!file) throw std::runtime_error(path.string() + ": cannot write");
    bool ok = std::fwrite(header.data(), 1, header.size(), file.get()) == header.size();
    ok = ok && writeRecords(file.get(), n, vertexSize, [&](std::size_t i, char* out) {
      auto put = [&out](const Eigen::Vector3f& v) {
        std::memcpy(out, v.data(), 3 * sizeof(float));
        out += 3 * sizeof(float);
      };
      put(toFileAxes(mesh.vertices[i], axes));
      if (withNormals) put(toFileAxes(mesh.normals[i], axes));
      if (withVelocities) put(toFileAxes(mesh.velocities[i], axes));
    });
    ok = ok && writeRecords(file.get(), mesh.triangles.size(), faceSize, [&](std::size_t t, char* out) {
      *out = 3;
      std::memcpy(out + 1, mesh.triangles[t].data(), 3 * sizeof(std::uint32_t));
    });
    if (!ok || std::fflush(file.get()) != 0) throw std::runtime_error(path.string() + ": write failed");
  });
}

TriangleMesh readPly(const std::filesystem::path& path, std::vector<std::string>* comments) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) throw InputError(path.string() + ": no such mesh file");
  PlyReader reader(path);
  const std::string& where = reader.where();
  if (comments) *comments = reader.comments();
  const auto& elements = reader.elements();
  int vertexElement = -1, faceElement = -1;
  for (std::size_t e = 0; e < elements.size(); ++e) {
    if (elements[e].name == "vertex" && vertexElement < 0) vertexElement = int(e);
    if (elements[e].name == "face" && faceElement < 0) faceElement = int(e);
  }
  if (vertexElement < 0) throw InputError(where + "no vertex element");
  const PlyElement& vertex = elements[std::size_t(vertexElement)];
  int column[9];
  const char* names[9] = {"x", "y", "z", "nx", "ny", "nz", "vx", "vy", "vz"};
  for (int k = 0; k < 9; ++k) column[k] = vertex.find(names[k]);
  if (column[0] < 0 || column[1] < 0 || column[2] < 0) throw InputError(where + "vertices lack x, y, z");
  const bool withNormals = column[3] >= 0 && column[4] >= 0 && column[5] >= 0;
  const bool withVelocities = column[6] >= 0 && column[7] >= 0 && column[8] >= 0;

  TriangleMesh mesh;
  mesh.vertices.reserve(vertex.count);
  auto vectorAt = [&column](const std::vector<double>& values, int first) {
    return Eigen::Vector3f(float(values[std::size_t(column[first])]), float(values[std::size_t(column[first + 1])]),
                           float(values[std::size_t(column[first + 2])]));
  };
  auto readVertices = [&] {
    reader.read(std::size_t(vertexElement), [&](const std::vector<double>& values, const std::vector<double>&) {
      mesh.vertices.push_back(vectorAt(values, 0));
      if (withNormals) mesh.normals.push_back(vectorAt(values, 3));
      if (withVelocities) mesh.velocities.push_back(vectorAt(values, 6));
    });
  };
  auto readFaces = [&] {
    const PlyElement& face = elements[std::size_t(faceElement)];
    int indices = face.find("vertex_indices");
    if (indices < 0) indices = face.find("vertex_index");
    if (indices < 0 || !face.properties[std::size_t(indices)].isList)
      throw InputError(where + "faces lack a vertex_indices list");
    for (std::size_t c = std::size_t(indices) + 1; c < face.properties.size(); ++c)
      if (face.properties[c].isList)
        throw InputError(where + "face property '" + face.properties[c].name + "' is a second list");
    mesh.triangles.reserve(face.count);
    std::size_t faceIndex = 0;
    reader.read(std::size_t(faceElement), [&](const std::vector<double>&, const std::vector<double>& list) {
      if (list.size() < 3) throw InputError(where + "face " + std::to_string(faceIndex) + " has fewer than 3 vertices");
      std::uint32_t corner[3];
      for (std::size_t k = 0; k < list.size(); ++k) {
        const double index = list[k];
        if (!(index >= 0 && index < double(mesh.vertices.size())) || index != std::floor(index))
          throw InputError(where + "face " + std::to_string(faceIndex) + ": vertex index " + std::to_string(index) +
                           " out of range");
        if (k < 2) {
          corner[k] = std::uint32_t(index);
          continue;
        }
        corner[2] = std::uint32_t(index);  // a fan from the first vertex
        mesh.triangles.push_back({corner[0], corner[1], corner[2]});
        corner[1] = corner[2];
      }
      ++faceIndex;
    });
  };
  // Faces index vertices, so vertices are read first whatever the element order.
  readVertices();
  if (faceElement >= 0) readFaces();
  return mesh;
}

TriangleMesh readMesh(const std::filesystem::path& path) {
  const std::string extension = path.extension().string();
  if (extension == ".obj") return readObj(path);
  if (extension == ".ply") return readPly(path);
  throw InputError(path.string() + ": unknown mesh file type (expected .obj or .ply)");
}

} // namespace cascade
