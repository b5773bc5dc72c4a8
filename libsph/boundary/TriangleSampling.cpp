// Type I samples on a triangle mesh (declared in MeshBoundary.h): area-true for
// any triangle shape, the SEED's 7 points (section 2.2) on the small ones.
//
// - Every mesh vertex once (positions that coincide are one vertex).
// - Every edge once, shared by its two triangles: evenly spaced points, the
//   fewest segments with none longer than the gap, at least 2 (the SEED's midpoint).
// - A small triangle (longest edge <= 2 gap: its midpoint gaps are <= gap) adds
//   its centroid: the SEED's 7 points.
// - A larger one adds rows parallel to its longest edge, evenly spaced (at most a
//   gap apart), each row's points evenly spaced (at most a gap apart) between the
//   places where the row comes within gap / 2 of the other two edges: closer in,
//   the edge's own samples cover. So the count is area / gap^2 plus the edges'
//   share, whatever the shape: a thin triangle is no longer sampled as if it were
//   square (the 1-to-4 subdivision this replaces gave a long 1:50 triangle ~80x its
//   area's samples, and rounded the segments up to a power of two).
#include "libsph/boundary/MeshBoundary.h"

#include "libsph/boundary/BoundarySampling.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <set>

namespace cascade {

namespace {
/// Segments of a stretch of length `length` with none longer than maxGap (at least `least`).
long segmentsFor(double length, double maxGap, long least) {
  const double segments = std::ceil(length / maxGap - 1e-4);
  return std::max(least, segments > 1e9 ? long(1e9) : long(segments));
}
} // namespace

namespace {
/// The samples as positions (computed as before, so static meshes keep their exact
/// points) and, if asked, as surface points (vertex weights), in the same order.
void sampleMesh(const TriangleMesh& mesh, Real maxGap, std::size_t* rowSampledTriangles, std::vector<Vec3r>& samples,
                std::vector<SurfacePoint>* points) {
  std::size_t rowSampled = 0;
  const double gap = double(maxGap);
  const auto vertex = [&](std::uint32_t v) { return mesh.vertices[v].cast<double>(); };
  const auto emit = [&](const Vec3d& x, std::array<std::uint32_t, 3> v, std::array<double, 3> w) {
    samples.push_back(x.cast<Real>());
    if (points) points->push_back(SurfacePoint{v, w});
  };
  // Vertices at the same position (seams left by hole filling) are one vertex:
  // each position is sampled once, and edges are keyed by these canonical indices.
  const std::vector<std::uint32_t> canonical = firstVertexAtSamePosition(mesh.vertices);
  // Vertices: once each.
  std::vector<char> used(mesh.vertices.size(), 0);
  for (const auto& t : mesh.triangles) used[canonical[t[0]]] = used[canonical[t[1]]] = used[canonical[t[2]]] = 1;
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v)
    if (used[v]) emit(vertex(std::uint32_t(v)), {std::uint32_t(v), 0, 0}, {1, 0, 0});
  // Edges: once each, the count from the length alone (both triangles agree).
  std::set<std::pair<std::uint32_t, std::uint32_t>> edges;
  for (const auto& tri : mesh.triangles)
    for (int e = 0; e < 3; ++e) {
      std::uint32_t a = canonical[tri[e]], b = canonical[tri[(e + 1) % 3]];
      if (a > b) std::swap(a, b);
      if (a != b) edges.emplace(a, b);
    }
  for (const auto& [first, second] : edges) {
    const Vec3d a = vertex(first), b = vertex(second);
    const long n = segmentsFor((b - a).norm(), gap, 2);
    for (long q = 1; q < n; ++q) {
      const double f = double(q) / double(n);
      emit(a + f * (b - a), {first, second, 0}, {1 - f, f, 0});
    }
  }
  // Triangles: the centroid of a small one, rows inside a larger one.
  for (const auto& tri : mesh.triangles) {
    int base = 0;  // the longest edge runs from corner `base` to the next
    double longest = -1;
    for (int e = 0; e < 3; ++e) {
      const double length = (vertex(tri[(e + 1) % 3]) - vertex(tri[e])).norm();
      if (length > longest) longest = length, base = e;
    }
    const std::array<std::uint32_t, 3> corner{canonical[tri[base]], canonical[tri[(base + 1) % 3]],
                                              canonical[tri[(base + 2) % 3]]};
    const Vec3d a = vertex(tri[base]), b = vertex(tri[(base + 1) % 3]), c = vertex(tri[(base + 2) % 3]);
    if (longest <= 2 * gap) {
      emit((a + b + c) / 3.0, corner, {1.0 / 3, 1.0 / 3, 1.0 / 3});
      continue;
    }
    ++rowSampled;
    const Vec3d along = (b - a) / longest;
    const double height = ((c - a) - (c - a).dot(along) * along).norm();
    // sin of the angles at a and b (both acute: ab is the longest edge)
    const double lengthAC = (c - a).norm(), lengthBC = (c - b).norm();
    if (!(height > 0) || !(lengthAC > 0) || !(lengthBC > 0)) continue;  // degenerate: its edges sample it
    const double sinA = height / lengthAC, sinB = height / lengthBC;
    const long rows = segmentsFor(height, gap, 1);
    // left + s along = a + t (c - a) + (s / longest) (b - a)
    const auto rowPoint = [&](double t, const Vec3d& left, double s) {
      const double u = s / longest;
      emit(left + s * along, corner, {1 - t - u, u, t});
    };
    for (long k = 1; k < rows; ++k) {
      const double t = double(k) / double(rows);
      const Vec3d left = a + t * (c - a);
      const double length = (1 - t) * longest;
      const double begin = 0.5 * gap / sinA, end = length - 0.5 * gap / sinB;
      const double span = end - begin;
      if (span < 0) continue;  // the whole row lies within gap / 2 of the side edges
      if (span < 0.5 * gap) {
        rowPoint(t, left, begin + 0.5 * span);
        continue;
      }
      const long n = segmentsFor(span, gap, 1);
      for (long q = 0; q <= n; ++q) rowPoint(t, left, begin + span * double(q) / double(n));
    }
  }
  // Degenerate or folded triangles (crack fans of hole filling) put points
  // where an edge or another triangle already has one: keep those once.
  std::vector<std::size_t> kept;
  removeDuplicateSamples(samples, maxGap * Real(1e-3), points ? &kept : nullptr);
  if (points) {
    std::vector<SurfacePoint> keptPoints;
    keptPoints.reserve(kept.size());
    for (std::size_t k : kept) keptPoints.push_back((*points)[k]);
    points->swap(keptPoints);
  }
  if (rowSampledTriangles) *rowSampledTriangles = rowSampled;
}
} // namespace

std::vector<Vec3r> sampleTriangles(const TriangleMesh& mesh, Real maxGap, std::size_t* rowSampledTriangles) {
  std::vector<Vec3r> samples;
  sampleMesh(mesh, maxGap, rowSampledTriangles, samples, nullptr);
  return samples;
}

std::vector<SurfacePoint> sampleTrianglePoints(const TriangleMesh& mesh, Real maxGap) {
  std::vector<Vec3r> samples;
  std::vector<SurfacePoint> points;
  sampleMesh(mesh, maxGap, nullptr, samples, &points);
  return points;
}

} // namespace cascade
