#include "surfacing/MeshCleanup.h"

#include "surfacing/detail/Profile.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>

#include <cmath>
#include <numeric>

namespace cascade::surfacing {

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using CgalMesh = CGAL::Surface_mesh<Kernel::Point_3>;

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

CgalMesh toCgal(const TriangleMesh& mesh) {
  CgalMesh out;
  out.reserve(CgalMesh::size_type(mesh.vertices.size()), CgalMesh::size_type(3 * mesh.triangles.size() / 2),
              CgalMesh::size_type(mesh.triangles.size()));
  std::vector<CgalMesh::Vertex_index> vertex;
  vertex.reserve(mesh.vertices.size());
  for (const auto& p : mesh.vertices) vertex.push_back(out.add_vertex(Kernel::Point_3(p.x(), p.y(), p.z())));
  for (const auto& t : mesh.triangles) out.add_face(vertex[t[0]], vertex[t[1]], vertex[t[2]]);  // rejects non-manifold
  return out;
}

TriangleMesh fromCgal(const CgalMesh& mesh) {
  TriangleMesh out;
  std::vector<std::uint32_t> index(mesh.num_vertices() + mesh.number_of_removed_vertices(), 0);
  for (auto v : mesh.vertices()) {
    index[v.idx()] = std::uint32_t(out.vertices.size());
    const auto& p = mesh.point(v);
    out.vertices.emplace_back(float(p.x()), float(p.y()), float(p.z()));
  }
  for (auto f : mesh.faces()) {
    std::array<std::uint32_t, 3> t{};
    int k = 0;
    for (auto v : CGAL::vertices_around_face(mesh.halfedge(f), mesh))
      if (k < 3) t[k++] = index[v.idx()];
    if (k == 3) out.triangles.push_back(t);
  }
  return out;
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
  UnionFind components(mesh.vertices.size());
  for (const auto& t : mesh.triangles) {
    components.unite(t[0], t[1]);
    components.unite(t[0], t[2]);
  }
  // Roots are the smallest index of their set, so parent[v] <= v: in increasing
  // order one step from each vertex reaches its root.
  std::vector<std::uint32_t>& root = components.parent;
  for (std::size_t v = 0; v < root.size(); ++v) root[v] = root[root[v]];
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
  if ((settings.remeshEdgeLength > 0 || (settings.triangleBudget > 0 &&
                                          mesh.triangles.size() > settings.triangleBudget)) &&
      !mesh.triangles.empty()) {
    CgalMesh cgalMesh = toCgal(mesh);
    if (settings.remeshEdgeLength > 0)
      CGAL::Polygon_mesh_processing::isotropic_remeshing(faces(cgalMesh), settings.remeshEdgeLength, cgalMesh);
    if (settings.triangleBudget > 0 && cgalMesh.number_of_faces() > settings.triangleBudget) {
      namespace SMS = CGAL::Surface_mesh_simplification;
      // Stops below a number of edges; a closed triangle mesh has 3/2 edges per face.
      SMS::Count_stop_predicate<CgalMesh> stop(settings.triangleBudget * 3 / 2);
      SMS::edge_collapse(cgalMesh, stop);
    }
    cgalMesh.collect_garbage();
    mesh = fromCgal(cgalMesh);
  }

  // 5. Normals.
  computeVertexNormals(mesh);
  profile.lap("cleanup: normals");
  return stats;
}

} // namespace cascade::surfacing
