#include "surfacing/MeshCleanup.h"

#include "surfacing/detail/MeshRemeshing.h"
#include "surfacing/detail/Profile.h"

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>

#include <cmath>
#include <numeric>

namespace cascade::surfacing {

namespace {

double tetraVolume(const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& c) {
  const Eigen::Vector3d ad = a.cast<double>(), bd = b.cast<double>(), cd = c.cast<double>();
  return ad.dot(bd.cross(cd)) / 6.0;
}

struct UnionFind {
  std::vector<std::uint32_t> parent;
  explicit UnionFind(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  std::uint32_t find(std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void unite(std::uint32_t a, std::uint32_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);  // deterministic roots
  }
};

} // namespace

// Union-find over two fixed halves of the triangles in parallel, then the second
// half's sets merged into the first's: roots are the smallest index of their set
// whatever the order of the unions, so the result is deterministic.
std::vector<std::uint32_t> componentRoots(const TriangleMesh& mesh) {
  const std::size_t half = mesh.triangles.size() / 2;
  UnionFind first(mesh.vertices.size()), second(mesh.vertices.size());
  auto uniteTriangles = [&](std::size_t begin, std::size_t end, UnionFind& sets) {
    for (std::size_t i = begin; i < end; ++i) {
      const auto& t = mesh.triangles[i];
      sets.unite(t[0], t[1]);
      sets.unite(t[0], t[2]);
    }
  };
  tbb::parallel_invoke([&] { uniteTriangles(0, half, first); },
                       [&] { uniteTriangles(half, mesh.triangles.size(), second); });
  for (std::uint32_t v = 0; v < std::uint32_t(mesh.vertices.size()); ++v) {
    const std::uint32_t other = second.find(v);
    if (other != v) first.unite(v, other);
  }
  // Roots are the smallest index of their set, so parent[v] <= v: in increasing
  // order one step from each vertex reaches its root.
  std::vector<std::uint32_t> root = std::move(first.parent);
  for (std::size_t v = 0; v < root.size(); ++v) root[v] = root[root[v]];
  return root;
}

namespace {

void removeUnreferencedVertices(TriangleMesh& mesh) {
  std::vector<std::uint32_t> remap(mesh.vertices.size(), std::uint32_t(-1));
  for (const auto& t : mesh.triangles)
    for (std::uint32_t v : t) remap[v] = 0;
  std::uint32_t next = 0;
  for (std::size_t v = 0; v < remap.size(); ++v)
    if (remap[v] == 0) {
      mesh.vertices[next] = mesh.vertices[v];
      remap[v] = next++;
    }
  mesh.vertices.resize(next);
  if (!mesh.normals.empty()) {  // normals follow their vertices
    for (std::size_t v = 0; v < remap.size(); ++v)
      if (remap[v] != std::uint32_t(-1)) mesh.normals[remap[v]] = mesh.normals[v];
    mesh.normals.resize(next);
  }
  for (auto& t : mesh.triangles)
    for (std::uint32_t& v : t) v = remap[v];
}

/// Keeps the triangles whose flag is set, in order (no copy if all are kept);
/// returns how many went.
std::size_t keepFlagged(TriangleMesh& mesh, const std::vector<std::uint8_t>& keep) {
  std::size_t count = 0;
  for (std::uint8_t k : keep) count += k;
  if (count == keep.size()) return 0;
  std::vector<std::array<std::uint32_t, 3>> kept;
  kept.reserve(count);
  for (std::size_t i = 0; i < keep.size(); ++i)
    if (keep[i]) kept.push_back(mesh.triangles[i]);
  mesh.triangles.swap(kept);
  return keep.size() - count;
}

} // namespace

double meshVolume(const TriangleMesh& mesh) {
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, mesh.triangles.size(), 16384), 0.0,
      [&](const auto& range, double sum) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          const auto& t = mesh.triangles[i];
          sum += tetraVolume(mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]]);
        }
        return sum;
      },
      [](double a, double b) { return a + b; });
}

MeshCleanupStats cleanupMesh(TriangleMesh& mesh, const MeshCleanupSettings& settings) {
  MeshCleanupStats stats;
  detail::ProfileClock profile;
  const std::size_t vertexCount = mesh.vertices.size(), triangleCount = mesh.triangles.size();
  // 1. Vertex-connected components.
  const std::vector<std::uint32_t> root = componentRoots(mesh);
  profile.lap("cleanup: components");

  // 2. One pass over the triangles for the face normal n = (b - a) x (c - a) (twice the
  // area-weighted normal), the degenerate flag (a repeated vertex, or n = 0) and the
  // component's volume, the tetrahedron (o, a, b, c) = (a - o) . n / 6 with o the
  // component's root vertex (a local origin, for precision). Two fixed halves of the
  // triangles in parallel, each into arrays of its own, added in order: deterministic.
  std::vector<std::uint8_t> degenerate(triangleCount);
  struct Sums {
    std::vector<Eigen::Vector3f> normal;
    std::vector<double> volume;
  };
  Sums sums[2];
  auto accumulate = [&](std::size_t begin, std::size_t end, Sums& into) {
    into.normal.assign(vertexCount, Eigen::Vector3f::Zero());
    into.volume.assign(vertexCount, 0.0);
    for (std::size_t i = begin; i < end; ++i) {
      const auto& t = mesh.triangles[i];
      const Eigen::Vector3f &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
      const Eigen::Vector3f n = (b - a).cross(c - a);
      const bool bad = t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || !(n.squaredNorm() > 0);
      degenerate[i] = bad;
      if (bad) continue;
      const std::uint32_t r = root[t[0]];
      into.volume[r] += (a - mesh.vertices[r]).cast<double>().dot(n.cast<double>()) / 6.0;
      for (std::uint32_t v : t) into.normal[v] += n;
    }
  };
  const std::size_t half = triangleCount / 2;
  tbb::parallel_invoke([&] { accumulate(0, half, sums[0]); }, [&] { accumulate(half, triangleCount, sums[1]); });
  std::vector<double>& volume = sums[0].volume;
  double total = 0;
  for (std::size_t v = 0; v < vertexCount; ++v) {
    volume[v] += sums[1].volume[v];
    if (root[v] == v && volume[v] != 0) {
      ++stats.components;
      total += volume[v];
    }
  }
  // Components below the volume threshold (also open or flat ones, of no volume) go.
  if (settings.minComponentVolume > 0)
    for (std::size_t v = 0; v < vertexCount; ++v)
      if (root[v] == v && volume[v] != 0 && std::abs(volume[v]) < settings.minComponentVolume)
        ++stats.droppedComponents, total -= volume[v];
  std::vector<std::uint8_t> keep(triangleCount);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, triangleCount, 16384), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i)
      keep[i] = !degenerate[i] && (settings.minComponentVolume <= 0 ||
                                   std::abs(volume[root[mesh.triangles[i][0]]]) >= settings.minComponentVolume);
  });
  for (std::size_t i = 0; i < triangleCount; ++i) stats.degenerateTriangles += degenerate[i];
  const std::size_t dropped = keepFlagged(mesh, keep);

  // 3. Outward orientation: the extractor's is consistent, so all or nothing.
  stats.flipped = total < 0;
  if (stats.flipped)
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mesh.triangles.size(), 16384), [&](const auto& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i) std::swap(mesh.triangles[i][1], mesh.triangles[i][2]);
    });
  // Area-weighted vertex normals from the sums (turned with the triangles).
  mesh.normals.swap(sums[0].normal);
  const float sign = stats.flipped ? -1.0f : 1.0f;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, vertexCount, 8192), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const Eigen::Vector3f sum = mesh.normals[i] + sums[1].normal[i];
      const float length = sum.norm();
      mesh.normals[i] = length > 0 ? Eigen::Vector3f(sum * (sign / length)) : Eigen::Vector3f(0, 0, 1);
    }
  });
  profile.lap("cleanup: degenerate, volumes, normals");
  if (dropped > 0) removeUnreferencedVertices(mesh);
  profile.lap("cleanup: unreferenced");

  // 4. CGAL remeshing / decimation (new triangles: normals again; CGAL's work dwarfs them).
  if (detail::remeshAndDecimate(mesh, settings.remeshEdgeLength, settings.triangleBudget)) mesh.computeNormals();
  return stats;
}

} // namespace cascade::surfacing
