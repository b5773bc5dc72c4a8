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

/// The root (smallest vertex index) of each vertex's vertex-connected component.
/// Union-find over two fixed halves of the triangles in parallel, then the second
/// half's sets merged into the first's: roots are the smallest index of their
/// set whatever the order of the unions, so the result is deterministic.
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
  for (auto& t : mesh.triangles)
    for (std::uint32_t& v : t) v = remap[v];
}

void computeVertexNormals(TriangleMesh& mesh) {
  // Area-weighted (the unnormalised face normal), summed per vertex. Two fixed
  // halves of the triangle list accumulate into their own arrays in parallel and
  // are added in a fixed order: the same result for any number of threads.
  const std::size_t n = mesh.vertices.size(), half = mesh.triangles.size() / 2;
  std::vector<Eigen::Vector3f> second(n, Eigen::Vector3f::Zero());
  mesh.normals.assign(n, Eigen::Vector3f::Zero());
  auto accumulate = [&](std::size_t begin, std::size_t end, std::vector<Eigen::Vector3f>& normals) {
    for (std::size_t i = begin; i < end; ++i) {
      const auto& t = mesh.triangles[i];
      const Eigen::Vector3f normal =
          (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
      for (std::uint32_t v : t) normals[v] += normal;
    }
  };
  tbb::parallel_invoke([&] { accumulate(0, half, mesh.normals); },
                       [&] { accumulate(half, mesh.triangles.size(), second); });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 8192), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const Eigen::Vector3f sum = mesh.normals[i] + second[i];
      const float length = sum.norm();
      mesh.normals[i] = length > 0 ? Eigen::Vector3f(sum / length) : Eigen::Vector3f(0, 0, 1);
    }
  });
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
  // 1. Degenerate triangles (tested in parallel, kept in order).
  std::vector<std::uint8_t> good(mesh.triangles.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mesh.triangles.size(), 16384), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const auto& t = mesh.triangles[i];
      const bool repeated = t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
      good[i] = !repeated && (mesh.vertices[t[1]] - mesh.vertices[t[0]])
                                     .cross(mesh.vertices[t[2]] - mesh.vertices[t[0]])
                                     .squaredNorm() > 0;
    }
  });
  // Keeps the triangles whose flag is set, in order (no copy if all are kept).
  auto keepFlagged = [&mesh](const std::vector<std::uint8_t>& keep) {
    std::size_t count = 0;
    for (std::uint8_t k : keep) count += k;
    if (count == keep.size()) return std::size_t(0);
    std::vector<std::array<std::uint32_t, 3>> kept;
    kept.reserve(count);
    for (std::size_t i = 0; i < keep.size(); ++i)
      if (keep[i]) kept.push_back(mesh.triangles[i]);
    mesh.triangles.swap(kept);
    return keep.size() - count;
  };
  stats.degenerateTriangles = keepFlagged(good);

  profile.lap("cleanup: degenerate");
  // 2. Components and their volumes (relative to a local origin, for precision).
  std::vector<std::uint32_t> root = componentRoots(mesh);
  // Volumes: two fixed halves of the triangles in parallel, added in order.
  std::vector<double> volume(mesh.vertices.size(), 0.0), secondHalf(mesh.vertices.size(), 0.0);
  auto addVolumes = [&](std::size_t begin, std::size_t end, std::vector<double>& sum) {
    for (std::size_t i = begin; i < end; ++i) {
      const auto& t = mesh.triangles[i];
      const std::uint32_t r = root[t[0]];
      const Eigen::Vector3f& origin = mesh.vertices[r];
      sum[r] += tetraVolume(mesh.vertices[t[0]] - origin, mesh.vertices[t[1]] - origin,
                            mesh.vertices[t[2]] - origin);
    }
  };
  const std::size_t half = mesh.triangles.size() / 2;
  tbb::parallel_invoke([&] { addVolumes(0, half, volume); },
                       [&] { addVolumes(half, mesh.triangles.size(), secondHalf); });
  double total = 0;
  for (std::size_t v = 0; v < volume.size(); ++v) {
    volume[v] += secondHalf[v];
    if (root[v] == v && volume[v] != 0) {
      ++stats.components;
      total += volume[v];
    }
  }
  if (settings.minComponentVolume > 0) {
    for (std::size_t v = 0; v < volume.size(); ++v)
      if (root[v] == v && volume[v] != 0 && std::abs(volume[v]) < settings.minComponentVolume)
        ++stats.droppedComponents, total -= volume[v];
    std::vector<std::uint8_t> keep(mesh.triangles.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, keep.size(), 16384), [&](const auto& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i)
        keep[i] = std::abs(volume[root[mesh.triangles[i][0]]]) >= settings.minComponentVolume;
    });
    keepFlagged(keep);
  }

  // 3. Outward orientation.
  if (total < 0) {
    stats.flipped = true;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mesh.triangles.size(), 16384), [&](const auto& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i) std::swap(mesh.triangles[i][1], mesh.triangles[i][2]);
    });
  }
  profile.lap("cleanup: components, orient");
  removeUnreferencedVertices(mesh);
  profile.lap("cleanup: unreferenced");

  // 4. CGAL remeshing / decimation.
  if (settings.remeshEdgeLength > 0 || (settings.triangleBudget > 0 && mesh.triangles.size() > settings.triangleBudget))
    detail::remeshAndDecimate(mesh, settings.remeshEdgeLength, settings.triangleBudget);

  // 5. Normals.
  computeVertexNormals(mesh);
  profile.lap("cleanup: normals");
  return stats;
}

} // namespace cascade::surfacing
