#include "libsph/io/TriangleMesh.h"
#include "libsph/Version.h"

#include "libsph/Errors.h"
#include "libsph/io/AtomicFile.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <string_view>

#include <tbb/parallel_pipeline.h>

#include <fcntl.h>

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
  const bool keepVelocities =
      velocities.size() == vertices.size() && other.velocities.size() == other.vertices.size();
  vertices.insert(vertices.end(), other.vertices.begin(), other.vertices.end());
  if (keepNormals) normals.insert(normals.end(), other.normals.begin(), other.normals.end());
  else normals.clear();
  if (keepVelocities) velocities.insert(velocities.end(), other.velocities.begin(), other.velocities.end());
  else velocities.clear();
  for (const auto& t : other.triangles)
    triangles.push_back({t[0] + vertexOffset, t[1] + vertexOffset, t[2] + vertexOffset});
  for (const auto& g : other.groups)
    groups.push_back({g.name, g.begin + triangleOffset, g.end + triangleOffset});
}

namespace {

/// The eight decimal digits of `value` < 10^8 as eight bytes 0..9 of a word,
/// the most significant digit in the lowest byte (first in memory on a
/// little-endian machine): two 4-digit halves, then 2-digit quarters, then
/// digits, each split by a multiply-and-shift division in every lane at once
/// (x / 100 = (x * 10486) >> 20 for x < 10^4; x / 10 = (x * 103) >> 10 for x < 100).
std::uint64_t digitBytes(std::uint32_t value) {
  std::uint64_t x = (value / 10000) | (std::uint64_t(value % 10000) << 32);
  std::uint64_t q = ((x * 10486) >> 20) & 0x0000007F0000007Full;
  x = q | ((x - q * 100) << 16);
  q = ((x * 103) >> 10) & 0x000F000F000F000Full;
  return q | ((x - q * 10) << 8);
}

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "digit words are laid out for little-endian stores");
constexpr std::uint64_t kAsciiZeros = 0x3030303030303030ull;

/// Stores the eight bytes of `word` at `out` (the buffers keep slack for it).
inline void store8(char* out, std::uint64_t word) { std::memcpy(out, &word, sizeof word); }

/// The text of `value` < 10^8 as a word of up to eight characters, and its length.
std::uint64_t shortIndexText(std::uint32_t value, int& length) {
  const std::uint64_t digits = digitBytes(value);
  // Leading zero digits are the low zero bytes; at least one digit stays.
  const int leadingZeros = digits ? __builtin_ctzll(digits) / 8 : 7;
  length = 8 - leadingZeros;
  return (digits | kAsciiZeros) >> (8 * leadingZeros);
}

constexpr std::uint64_t kShortIndexLimit = 100000000u;

/// Decimal digits of an index. Writes up to 8 bytes past the returned end for
/// values below 10^8 (the buffers keep slack); larger values take a loop.
char* putIndex(char* out, std::uint64_t value) {
  if (value < kShortIndexLimit) {
    int length;
    store8(out, shortIndexText(std::uint32_t(value), length));
    return out + length;
  }
  char buffer[24];
  char* end = buffer + sizeof buffer;
  char* p = end;
  for (; value; value /= 10) *--p = char('0' + value % 10);
  std::memcpy(out, p, std::size_t(end - p));
  return out + (end - p);
}

/// 10^k as doubles, k in [-60, 60].
struct Pow10Table {
  double value[121];
  Pow10Table() {
    for (int k = -60; k <= 60; ++k) value[k + 60] = std::pow(10.0, k);
  }
};

/// A float as text that reads back to the same float: 9 significant digits
/// (FLT_DECIMAL_DIG, enough for every float), trailing zeros dropped, plain
/// notation for 1e-5 <= |value| < 1e9. The digits come from the exact double of
/// the value times a power of ten (error ~1e-16, far inside the half unit of
/// the 9th digit that the round trip allows), and are placed with fixed-size
/// stores of whole digit words (no per-digit loop), several times faster than
/// std::to_chars' shortest form, which is a digit or two shorter. Writes up to
/// 16 bytes past the returned end (the buffers keep slack).
char* putFloat(char* out, float value) {
  if (!std::isfinite(value) || value == 0) return std::to_chars(out, out + 32, value).ptr;
  static const Pow10Table table;
  const double* pow10 = table.value + 60;
  double x = value;
  if (x < 0) {
    *out++ = '-';
    x = -x;
  }
  std::uint32_t bits;
  std::memcpy(&bits, &value, sizeof bits);
  const int exponent2 = int((bits >> 23) & 0xff) - 127;  // |value| in [2^e, 2^(e+1)) for normal floats
  int exponent10 = exponent2 < -126 ? -46 : (exponent2 * 1233) >> 12;  // floor(log10 |value|), or one less
  while (x >= pow10[exponent10 + 1]) ++exponent10;
  std::uint32_t digits = std::uint32_t(x * pow10[8 - exponent10] + 0.5);
  if (digits >= 1000000000u) {  // rounded up to 10^9
    digits = (digits + 5) / 10;
    ++exponent10;
  }
  // 9 digits (digits >= 10^8): the first, and a word of the other eight.
  const char first = char('0' + digits / 100000000u);
  const std::uint64_t rest = digitBytes(digits % 100000000u);
  const int restLength = rest ? 8 - __builtin_clzll(rest) / 8 : 0;  // trailing zeros dropped
  const std::uint64_t restText = rest | kAsciiZeros;
  if (exponent10 < 0 && exponent10 >= -5) {  // 0.000ddd
    store8(out, 0x3030303030302e30ull);  // "0.000000"
    out += 1 - exponent10;
    *out++ = first;
    store8(out, restText);
    return out + restLength;
  }
  if (exponent10 >= 0 && exponent10 < 9) {  // ddd.ddd
    char d[24] = {};
    d[0] = first;
    store8(d + 1, restText);
    std::memcpy(out, d, 16);
    out += exponent10 + 1;
    if (restLength > exponent10) {
      *out++ = '.';
      std::memcpy(out, d + exponent10 + 1, 8);
      out += restLength - exponent10;
    }
    return out;
  }
  *out++ = first;  // d.ddde+XX
  if (restLength > 0) {
    *out++ = '.';
    store8(out, restText);
    out += restLength;
  }
  *out++ = 'e';
  int e = exponent10;
  *out++ = e < 0 ? '-' : '+';
  e = std::abs(e);
  *out++ = char('0' + e / 10);
  *out++ = char('0' + e % 10);
  return out;
}

/// "tag x y z\n" with the axis mapping applied.
char* putVector(char* out, const char* tag, std::size_t tagLength, const Eigen::Vector3f& v, MeshAxes axes) {
  std::memcpy(out, tag, tagLength);
  out += tagLength;
  const Eigen::Vector3f c = toFileAxes(v, axes);
  for (float value : {c.x(), c.y(), c.z()}) {
    *out++ = ' ';
    out = putFloat(out, value);
  }
  *out++ = '\n';
  return out;
}

/// One block of lines of the file: [begin, end) of one section.
struct ObjBlock {
  enum Section { Vertices, Normals, Faces } section = Vertices;
  std::size_t begin = 0, end = 0;
  char* text = nullptr;  // one of the writer's reused buffers
  std::size_t size = 0;
};

constexpr std::size_t kObjBlockLines = 16384;
constexpr std::size_t kObjBlocksInFlight = 8;
constexpr std::size_t kMaxVectorLine = 4 + 3 * 33 + 1;    // "vn" and three floats
constexpr std::size_t kMaxFaceLine = 2 + 3 * (2 * 20 + 3) + 1;
constexpr std::size_t kObjLineSlack = 32;  // fixed-size stores run up to 16 bytes past a line's end
constexpr std::size_t kObjWritebackChunk = std::size_t(32) << 20;  // bytes written between writeback starts

} // namespace

std::string prefixedLines(const std::string& text, const std::string& prefix) {
  std::string lines;
  for (std::size_t begin = 0; begin < text.size();) {
    const std::size_t end = std::min(text.find('\n', begin), text.size());
    lines += prefix;
    lines.append(text, begin, end - begin);
    lines += "\n";
    begin = end + 1;
  }
  return lines;
}

void writeObj(const std::filesystem::path& path, const TriangleMesh& mesh) { writeObj(path, mesh, std::string()); }

void writeObj(const std::filesystem::path& path, const TriangleMesh& mesh, const std::string& comment,
              MeshAxes axes) {
  const bool withNormals = mesh.normals.size() == mesh.vertices.size() && !mesh.normals.empty();
  // Group lines: "g NAME" before triangle groups[g].begin, for groups in order
  // (a group starting before the previous one, or past the end, ends the list).
  std::vector<std::pair<std::size_t, std::size_t>> groupLines;  // (triangle, group)
  for (std::size_t g = 0, previous = 0; g < mesh.groups.size(); ++g) {
    const std::size_t begin = mesh.groups[g].begin;
    if (begin < previous || begin >= mesh.triangles.size()) break;
    groupLines.emplace_back(begin, g);
    previous = begin;
  }

  std::string header = "# Cascade triangle mesh: " + std::to_string(mesh.vertices.size()) + " vertices, " +
                       std::to_string(mesh.triangles.size()) + " triangles\n";
  header += prefixedLines(comment, "# ");
  header += "# " + writtenBy() + "\n";

  // The blocks of the file, in order.
  std::vector<ObjBlock> blocks;
  auto addSection = [&](ObjBlock::Section section, std::size_t count) {
    for (std::size_t begin = 0; begin < count; begin += kObjBlockLines)
      blocks.push_back({section, begin, std::min(count, begin + kObjBlockLines), {}});
  };
  addSection(ObjBlock::Vertices, mesh.vertices.size());
  if (withNormals) addSection(ObjBlock::Normals, mesh.normals.size());
  addSection(ObjBlock::Faces, mesh.triangles.size());

  auto format = [&](ObjBlock& block) {
    char* out = block.text;
    switch (block.section) {
      case ObjBlock::Vertices:
        for (std::size_t i = block.begin; i < block.end; ++i) out = putVector(out, "v", 1, mesh.vertices[i], axes);
        break;
      case ObjBlock::Normals:
        for (std::size_t i = block.begin; i < block.end; ++i) out = putVector(out, "vn", 2, mesh.normals[i], axes);
        break;
      case ObjBlock::Faces: {
        auto group = std::lower_bound(groupLines.begin(), groupLines.end(), std::make_pair(block.begin, std::size_t(0)));
        for (std::size_t t = block.begin; t < block.end; ++t) {
          for (; group != groupLines.end() && group->first == t; ++group) {
            const std::string& name = mesh.groups[group->second].name;
            *out++ = 'g';
            *out++ = ' ';
            std::memcpy(out, name.data(), name.size());
            out += name.size();
            *out++ = '\n';
          }
          *out++ = 'f';
          for (auto index : mesh.triangles[t]) {
            *out++ = ' ';
            const std::uint64_t value = std::uint64_t(index) + 1;
            if (withNormals && value < kShortIndexLimit) {  // "v//vn" with vn == v: the digits once, stored twice
              int length;
              const std::uint64_t text = shortIndexText(std::uint32_t(value), length);
              store8(out, text);
              out += length;
              *out++ = '/';
              *out++ = '/';
              store8(out, text);
              out += length;
              continue;
            }
            out = putIndex(out, value);
            if (withNormals) {
              *out++ = '/';
              *out++ = '/';
              out = putIndex(out, value);
            }
          }
          *out++ = '\n';
        }
        break;
      }
    }
    block.size = std::size_t(out - block.text);
  };
  // Buffers reused round robin: block i and block i + kObjBlocksInFlight are never
  // in the pipeline together (its output stage is serial and in order). Reusing
  // them spares the page faults of fresh multi-megabyte allocations.
  std::size_t capacity = kObjBlockLines * std::max(kMaxFaceLine, kMaxVectorLine) + kObjLineSlack;
  for (const auto& group : mesh.groups) capacity += group.name.size() + 3;
  std::vector<std::unique_ptr<char[]>> buffers(std::min(kObjBlocksInFlight, blocks.size()));
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    auto& buffer = buffers[b % kObjBlocksInFlight];
    if (!buffer) buffer.reset(new char[capacity]);
    blocks[b].text = buffer.get();
  }

  writeFileAtomically(path, [&](const std::filesystem::path& temp) {
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(temp.c_str(), "wb"), &std::fclose);
    if (!file) throw std::runtime_error(path.string() + ": cannot write");
    std::setvbuf(file.get(), nullptr, _IONBF, 0);  // whole blocks go straight to write(2)
    bool failed = std::fwrite(header.data(), 1, header.size(), file.get()) != header.size();
    // Format blocks in parallel, write them in file order; a few blocks in flight bound the memory.
    // Writeback of each written chunk starts at once (sync_file_range), so the disk works while
    // later blocks are formatted and the closing fsync (writeFileAtomically) has little left to wait for.
    std::size_t next = 0, written = header.size(), syncedFrom = 0;
    tbb::parallel_pipeline(
        kObjBlocksInFlight,
        tbb::make_filter<void, ObjBlock*>(tbb::filter_mode::serial_in_order,
                                          [&](tbb::flow_control& control) -> ObjBlock* {
                                            if (next == blocks.size()) {
                                              control.stop();
                                              return nullptr;
                                            }
                                            return &blocks[next++];
                                          }) &
            tbb::make_filter<ObjBlock*, ObjBlock*>(tbb::filter_mode::parallel,
                                                   [&](ObjBlock* block) {
                                                     format(*block);
                                                     return block;
                                                   }) &
            tbb::make_filter<ObjBlock*, void>(tbb::filter_mode::serial_in_order, [&](ObjBlock* block) {
              if (!failed && std::fwrite(block->text, 1, block->size, file.get()) != block->size) failed = true;
              written += block->size;
              if (written - syncedFrom >= kObjWritebackChunk) {  // start writeback, don't wait for it
                ::sync_file_range(::fileno(file.get()), off64_t(syncedFrom), off64_t(written - syncedFrom),
                                  SYNC_FILE_RANGE_WRITE);
                syncedFrom = written;
              }
            }));
    if (failed || std::fflush(file.get()) != 0) throw std::runtime_error(path.string() + ": write failed");
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

std::vector<std::uint32_t> firstVertexAtSamePosition(const std::vector<Eigen::Vector3f>& vertices) {
  std::vector<std::uint32_t> first(vertices.size());
  std::map<std::array<float, 3>, std::uint32_t> seen;
  for (std::size_t v = 0; v < vertices.size(); ++v) {
    const Eigen::Vector3f& x = vertices[v];
    first[v] = seen.emplace(std::array<float, 3>{x.x(), x.y(), x.z()}, std::uint32_t(v)).first->second;
  }
  return first;
}

double surfaceArea(const TriangleMesh& mesh) {
  double area = 0;
  for (const auto& tri : mesh.triangles) {
    const Vec3d a = mesh.vertices[tri[0]].cast<double>();
    area += 0.5 * (mesh.vertices[tri[1]].cast<double>() - a).cross(mesh.vertices[tri[2]].cast<double>() - a).norm();
  }
  return area;
}

} // namespace cascade
