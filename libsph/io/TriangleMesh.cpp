#include "libsph/io/TriangleMesh.h"

#include "libsph/Errors.h"
#include "libsph/io/AtomicFile.h"

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <string_view>

namespace cascade {

void TriangleMesh::computeNormals() {
  normals.assign(vertices.size(), Eigen::Vector3f::Zero());
  for (const auto& t : triangles) {
    // Cross product length is twice the area: area weighting for free.
    const Eigen::Vector3f n =
        (vertices[t[1]] - vertices[t[0]]).cross(vertices[t[2]] - vertices[t[0]]);
    for (auto v : t) normals[v] += n;
  }
  for (auto& n : normals) {
    const float length = n.norm();
    n = length > 0 ? Eigen::Vector3f(n / length) : Eigen::Vector3f(0, 0, 1);
  }
}

void TriangleMesh::append(const TriangleMesh& other) {
  const auto vertexOffset = static_cast<std::uint32_t>(vertices.size());
  const std::size_t triangleOffset = triangles.size();
  const bool keepNormals = (normals.size() == vertices.size()) && (other.normals.size() == other.vertices.size());
  vertices.insert(vertices.end(), other.vertices.begin(), other.vertices.end());
  if (keepNormals) normals.insert(normals.end(), other.normals.begin(), other.normals.end());
  else normals.clear();
  for (const auto& t : other.triangles)
    triangles.push_back({t[0] + vertexOffset, t[1] + vertexOffset, t[2] + vertexOffset});
  for (const auto& g : other.groups)
    groups.push_back({g.name, g.begin + triangleOffset, g.end + triangleOffset});
}

namespace {

/// Appends text to a growing buffer flushed to a FILE in large blocks.
class BufferedWriter {
public:
  explicit BufferedWriter(std::FILE* file) : mFile(file) { mBuffer.reserve(kBlock + 256); }
  ~BufferedWriter() { flush(); }
  void put(std::string_view text) {
    mBuffer.append(text);
    if (mBuffer.size() >= kBlock) flush();
  }
  void putFloat(float value) {
    char buffer[32];
    const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
    mBuffer.append(buffer, result.ptr);
  }
  void putIndex(std::uint64_t value) {
    char buffer[24];
    const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
    mBuffer.append(buffer, result.ptr);
  }
  void flush() {
    if (!mBuffer.empty() && std::fwrite(mBuffer.data(), 1, mBuffer.size(), mFile) != mBuffer.size())
      mFailed = true;
    mBuffer.clear();
  }
  bool failed() const { return mFailed; }

private:
  static constexpr std::size_t kBlock = 1 << 20;
  std::FILE* mFile;
  std::string mBuffer;
  bool mFailed = false;
};

void putVector(BufferedWriter& out, const char* tag, const Eigen::Vector3f& v) {
  out.put(tag);
  for (int k = 0; k < 3; ++k) {
    out.put(" ");
    out.putFloat(v[k]);
  }
  out.put("\n");
}

} // namespace

void writeObj(const std::filesystem::path& path, const TriangleMesh& mesh) { writeObj(path, mesh, std::string()); }

void writeObj(const std::filesystem::path& path, const TriangleMesh& mesh, const std::string& comment) {
  writeFileAtomically(path, [&](const std::filesystem::path& temp) {
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(temp.c_str(), "wb"), &std::fclose);
    if (!file) throw std::runtime_error(path.string() + ": cannot write");
    BufferedWriter out(file.get());
    out.put("# Cascade triangle mesh: ");
    out.putIndex(mesh.vertices.size());
    out.put(" vertices, ");
    out.putIndex(mesh.triangles.size());
    out.put(" triangles\n");
    for (std::size_t begin = 0; begin < comment.size();) {
      const std::size_t end = std::min(comment.find('\n', begin), comment.size());
      out.put("# ");
      out.put(std::string_view(comment).substr(begin, end - begin));
      out.put("\n");
      begin = end + 1;
    }
    for (const auto& v : mesh.vertices) putVector(out, "v", v);
    const bool withNormals = mesh.normals.size() == mesh.vertices.size() && !mesh.normals.empty();
    if (withNormals)
      for (const auto& n : mesh.normals) putVector(out, "vn", n);
    std::size_t nextGroup = 0;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
      while (nextGroup < mesh.groups.size() && mesh.groups[nextGroup].begin == t) {
        out.put("g ");
        out.put(mesh.groups[nextGroup].name);
        out.put("\n");
        ++nextGroup;
      }
      out.put("f");
      for (auto index : mesh.triangles[t]) {
        out.put(" ");
        out.putIndex(index + 1);
        if (withNormals) {
          out.put("//");
          out.putIndex(index + 1);
        }
      }
      out.put("\n");
    }
    out.flush();
    if (out.failed() || std::fflush(file.get()) != 0)
      throw std::runtime_error(path.string() + ": write failed");
  });
}

namespace {

struct ObjParser {
  const std::filesystem::path& path;
  std::size_t line = 0;

  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(path.string() + ":" + std::to_string(line) + ": " + what);
  }

  static const char* skipSpace(const char* p, const char* end) {
    while (p < end && (*p == ' ' || *p == '\t' || *p == '\r')) ++p;
    return p;
  }

  Eigen::Vector3f parseVector(const char* p, const char* end) const {
    Eigen::Vector3f v;
    for (int k = 0; k < 3; ++k) {
      p = skipSpace(p, end);
      const auto result = std::from_chars(p, end, v[k]);
      if (result.ec != std::errc()) fail("malformed number");
      p = result.ptr;
    }
    return v;
  }

  /// Resolves a 1-based or negative OBJ index against `count` elements.
  std::uint32_t resolve(long index, std::size_t count) const {
    const long resolved = index > 0 ? index - 1 : static_cast<long>(count) + index;
    if (index == 0 || resolved < 0 || resolved >= static_cast<long>(count))
      fail("index " + std::to_string(index) + " out of range");
    return static_cast<std::uint32_t>(resolved);
  }
};

} // namespace

TriangleMesh readObj(const std::filesystem::path& path) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) throw InputError(path.string() + ": no such mesh file");
  const std::string text = readTextFile(path);
  TriangleMesh mesh;
  std::vector<Eigen::Vector3f> fileNormals;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> normalOf;  // (vertex, normal) pairs
  ObjParser parser{path};
  const char* p = text.data();
  const char* const end = p + text.size();
  std::vector<std::uint32_t> polygon;
  while (p < end) {
    const char* lineEnd = static_cast<const char*>(std::memchr(p, '\n', static_cast<std::size_t>(end - p)));
    if (!lineEnd) lineEnd = end;
    ++parser.line;
    const char* q = ObjParser::skipSpace(p, lineEnd);
    if (q + 1 < lineEnd && q[0] == 'v' && (q[1] == ' ' || q[1] == '\t')) {
      mesh.vertices.push_back(parser.parseVector(q + 2, lineEnd));
    } else if (q + 2 < lineEnd && q[0] == 'v' && q[1] == 'n' && (q[2] == ' ' || q[2] == '\t')) {
      fileNormals.push_back(parser.parseVector(q + 3, lineEnd));
    } else if (q + 1 < lineEnd && (q[0] == 'g' || q[0] == 'o') && (q[1] == ' ' || q[1] == '\t')) {
      const char* nameBegin = ObjParser::skipSpace(q + 2, lineEnd);
      const char* nameEnd = lineEnd;
      while (nameEnd > nameBegin && (nameEnd[-1] == ' ' || nameEnd[-1] == '\r')) --nameEnd;
      if (!mesh.groups.empty()) mesh.groups.back().end = mesh.triangles.size();
      mesh.groups.push_back({std::string(nameBegin, nameEnd), mesh.triangles.size(), mesh.triangles.size()});
    } else if (q + 1 < lineEnd && q[0] == 'f' && (q[1] == ' ' || q[1] == '\t')) {
      polygon.clear();
      const char* r = q + 2;
      while (true) {
        r = ObjParser::skipSpace(r, lineEnd);
        if (r >= lineEnd) break;
        long vertexIndex = 0;
        auto result = std::from_chars(r, lineEnd, vertexIndex);
        if (result.ec != std::errc()) parser.fail("malformed face");
        r = result.ptr;
        const std::uint32_t vertex = parser.resolve(vertexIndex, mesh.vertices.size());
        polygon.push_back(vertex);
        if (r < lineEnd && *r == '/') {  // a/b, a/b/c or a//c
          ++r;
          if (r < lineEnd && *r != '/') {
            long ignored = 0;
            result = std::from_chars(r, lineEnd, ignored);
            if (result.ec != std::errc()) parser.fail("malformed face");
            r = result.ptr;
          }
          if (r < lineEnd && *r == '/') {
            ++r;
            long normalIndex = 0;
            result = std::from_chars(r, lineEnd, normalIndex);
            if (result.ec != std::errc()) parser.fail("malformed face");
            r = result.ptr;
            normalOf.emplace_back(vertex, parser.resolve(normalIndex, fileNormals.size()));
          }
        }
        if (r < lineEnd && *r != ' ' && *r != '\t' && *r != '\r') parser.fail("malformed face");
      }
      if (polygon.size() < 3) parser.fail("face with fewer than 3 vertices");
      for (std::size_t k = 1; k + 1 < polygon.size(); ++k)
        mesh.triangles.push_back({polygon[0], polygon[k], polygon[k + 1]});
    }
    p = lineEnd + 1;
  }
  if (!mesh.groups.empty()) mesh.groups.back().end = mesh.triangles.size();
  if (!normalOf.empty()) {
    mesh.normals.assign(mesh.vertices.size(), Eigen::Vector3f::Zero());
    std::vector<char> hasNormal(mesh.vertices.size(), 0);
    for (const auto& [vertex, normal] : normalOf) {
      mesh.normals[vertex] = fileNormals[normal];
      hasNormal[vertex] = 1;
    }
    for (std::size_t v = 0; v < mesh.vertices.size(); ++v)
      if (!hasNormal[v]) { mesh.computeNormals(); break; }
  }
  return mesh;
}

} // namespace cascade
