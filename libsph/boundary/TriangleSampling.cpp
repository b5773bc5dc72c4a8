// SEED section 2.2: 7 type I particles per triangle (3 vertices, 3 edge
// midpoints, the centroid), triangles split 1-to-4 until no gap exceeds the
// limit (declared in MeshBoundary.h).
//
// A triangle split k times is the regular grid of m = 2^k segments per edge;
// its leaves' vertices and edge midpoints together are the regular grid of
// 2m segments, plus one centroid per leaf. So the samples are generated
// directly, each once: every mesh vertex; along every edge the points of the
// finer of its two triangles' grids; inside every triangle its grid's interior
// points and its leaves' centroids: no repeated points from shared leaf
// corners (the final hash pass only meets the few that degenerate triangles
// of hole filling repeat).
#include "libsph/boundary/MeshBoundary.h"

#include "libsph/boundary/BoundarySampling.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>

namespace cascade {

namespace {
/// Segments per edge of the triangle's 1-to-4 subdivision: the least power of
/// two m with longest edge / m <= 2 maxGap (then no vertex-midpoint gap exceeds maxGap).
long subdivisionSegments(Real longest, Real maxGap) {
  long m = 1;
  while (longest / Real(m) > 2 * maxGap && m < (1L << 20)) m *= 2;
  return m;
}
} // namespace

std::vector<Vec3r> sampleTrianglesSeed(const TriangleMesh& mesh, Real maxGap, std::size_t* subdividedTriangles) {
  std::vector<Vec3r> samples;
  std::size_t subdivided = 0;
  const auto vertex = [&](std::uint32_t v) { return mesh.vertices[v].cast<double>(); };
  // Vertices at the same position (seams left by hole filling) are one vertex:
  // each position is sampled once, and edges are keyed by these canonical indices.
  std::vector<std::uint32_t> canonical(mesh.vertices.size());
  {
    std::map<std::array<float, 3>, std::uint32_t> first;
    for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
      const Eigen::Vector3f& x = mesh.vertices[v];
      canonical[v] = first.emplace(std::array<float, 3>{x.x(), x.y(), x.z()}, std::uint32_t(v)).first->second;
    }
  }
  // Vertices: once each.
  std::vector<char> used(mesh.vertices.size(), 0);
  for (const auto& t : mesh.triangles) used[canonical[t[0]]] = used[canonical[t[1]]] = used[canonical[t[2]]] = 1;
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v)
    if (used[v]) samples.push_back(mesh.vertices[v].cast<Real>());
  // Subdivision of each triangle; each edge takes the finer of its two triangles.
  std::vector<long> segments(mesh.triangles.size(), 1);
  std::map<std::pair<std::uint32_t, std::uint32_t>, long> edgeSegments;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    Real longest = 0;
    for (int e = 0; e < 3; ++e)
      longest = std::max(longest, (mesh.vertices[tri[e]] - mesh.vertices[tri[(e + 1) % 3]]).cast<Real>().norm());
    segments[t] = subdivisionSegments(longest, maxGap);
    if (segments[t] > 1) ++subdivided;
    for (int e = 0; e < 3; ++e) {
      std::uint32_t a = canonical[tri[e]], b = canonical[tri[(e + 1) % 3]];
      if (a > b) std::swap(a, b);
      long& edge = edgeSegments[{a, b}];
      edge = std::max(edge, segments[t]);
    }
  }
  // Edges: the points between the end vertices of the 2m-segment grid (m = 1: the midpoint).
  for (const auto& [edge, m] : edgeSegments) {
    const Vec3d a = vertex(edge.first), b = vertex(edge.second);
    const long n = 2 * m;
    for (long q = 1; q < n; ++q) samples.push_back((a + (double(q) / double(n)) * (b - a)).cast<Real>());
  }
  // Triangles: interior points of the 2m grid, then the centroids of the m^2 leaves.
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    const Vec3d a = vertex(tri[0]), ab = vertex(tri[1]) - a, ac = vertex(tri[2]) - a;
    const long m = segments[t], n = 2 * m;
    const auto at = [&](double i, double j) { return (a + i * ab + j * ac).cast<Real>(); };
    for (long j = 1; j < n; ++j)
      for (long i = 1; i + j < n; ++i) samples.push_back(at(double(i) / double(n), double(j) / double(n)));
    const double third = 1.0 / 3.0;
    for (long j = 0; j < m; ++j)
      for (long i = 0; i + j < m; ++i) {
        samples.push_back(at((double(i) + third) / double(m), (double(j) + third) / double(m)));  // upward leaf
        if (i + j < m - 1)
          samples.push_back(at((double(i) + 2 * third) / double(m), (double(j) + 2 * third) / double(m)));  // downward
      }
  }
  // Degenerate or folded triangles (crack fans of hole filling) put points
  // where an edge or another triangle already has one: keep those once.
  removeDuplicateSamples(samples, maxGap * Real(1e-3));
  if (subdividedTriangles) *subdividedTriangles = subdivided;
  return samples;
}

} // namespace cascade
