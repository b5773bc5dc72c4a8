#include "libsph/boundary/MeshBoundary.h"

#include "libsph/Errors.h"
#include "libsph/boundary/BoundarySampling.h"
#include "libsph/boundary/TriangleBand.h"
#include "libsph/io/TriangleMesh.h"

// Heavy headers stay here (BRIEF: assimp / CGAL inside the .cpp files).
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/boost/graph/helpers.h>
#include <CGAL/Polygon_mesh_processing/border.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Polygon_mesh_processing/triangulate_faces.h>
#include <CGAL/boost/graph/Euler_operations.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <atomic>
#include <cmath>
#include <map>
#include <mutex>
#include <ostream>
#include <stdexcept>
#include <unordered_map>

namespace cascade {

namespace {

// Exact predicates (orientation, coplanarity) for hole filling, orientation and
// simplification: with a plain double kernel CGAL's preconditions fail on meshes
// with nearly flat or degenerate faces (a Debug build asserts).
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
namespace PMP = CGAL::Polygon_mesh_processing;
namespace SMS = CGAL::Surface_mesh_simplification;

SurfaceMesh toSurfaceMesh(const TriangleMesh& mesh, const std::string& context) {
  std::vector<Point> points;
  points.reserve(mesh.vertices.size());
  for (const Eigen::Vector3f& v : mesh.vertices) points.emplace_back(v.x(), v.y(), v.z());
  std::vector<std::vector<std::size_t>> polygons;
  polygons.reserve(mesh.triangles.size());
  for (const auto& t : mesh.triangles) polygons.push_back({t[0], t[1], t[2]});
  PMP::repair_polygon_soup(points, polygons);
  PMP::orient_polygon_soup(points, polygons);
  SurfaceMesh result;
  PMP::polygon_soup_to_polygon_mesh(points, polygons, result);
  if (result.number_of_faces() == 0) throw InputError(context + ": mesh has no valid triangles");
  return result;
}

TriangleMesh toTriangleMesh(const SurfaceMesh& mesh) {
  TriangleMesh result;
  std::vector<std::uint32_t> index(mesh.number_of_vertices() + mesh.number_of_removed_vertices(), 0);
  for (auto v : mesh.vertices()) {
    index[v.idx()] = static_cast<std::uint32_t>(result.vertices.size());
    const Point& p = mesh.point(v);
    result.vertices.emplace_back(float(p.x()), float(p.y()), float(p.z()));
  }
  for (auto f : mesh.faces()) {
    std::array<std::uint32_t, 3> tri{};
    int k = 0;
    for (auto v : CGAL::vertices_around_face(mesh.halfedge(f), mesh)) {
      if (k < 3) tri[k] = index[v.idx()];
      ++k;
    }
    if (k == 3) result.triangles.push_back(tri);
  }
  return result;
}

} // namespace

namespace {
/// Appends a part's triangles to `mesh`, welding vertices at identical positions (across
/// parts too, through `welded`) and dropping triangles that weld to a line or a point.
void addWelded(TriangleMesh& mesh, std::map<std::array<float, 3>, std::uint32_t>& welded,
               const std::vector<Eigen::Vector3f>& vertices,
               const std::vector<std::array<std::uint32_t, 3>>& triangles) {
  std::vector<std::uint32_t> index(vertices.size());
  for (std::size_t v = 0; v < vertices.size(); ++v) {
    const Eigen::Vector3f& p = vertices[v];
    auto [it, inserted] = welded.emplace(std::array<float, 3>{p.x(), p.y(), p.z()},
                                         static_cast<std::uint32_t>(mesh.vertices.size()));
    if (inserted) mesh.vertices.push_back(p);
    index[v] = it->second;
  }
  for (const auto& t : triangles) {
    const std::array<std::uint32_t, 3> tri{index[t[0]], index[t[1]], index[t[2]]};
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) continue;
    mesh.triangles.push_back(tri);
  }
}
} // namespace

TriangleMesh loadMeshFile(const std::filesystem::path& path) {
  if (!std::filesystem::exists(path)) throw InputError(path.string() + ": mesh file not found");
  TriangleMesh mesh;
  std::map<std::array<float, 3>, std::uint32_t> welded;
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return std::tolower(c); });
  if (extension == ".ply") {
    // Cascade's own PLY reader (fuzzed; libsph/io/Ply.h): assimp 5.2's reads past the
    // end of a malformed header.
    const TriangleMesh file = readPly(path);
    addWelded(mesh, welded, file.vertices, file.triangles);
  } else {
    Assimp::Importer importer;
    const aiScene* scene = importer.ReadFile(
        path.string(), aiProcess_Triangulate | aiProcess_JoinIdenticalVertices | aiProcess_PreTransformVertices);
    if (!scene || !scene->mRootNode)
      throw InputError(path.string() + ": cannot load mesh (" + importer.GetErrorString() + ")");
    for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
      const aiMesh* part = scene->mMeshes[m];
      std::vector<Eigen::Vector3f> vertices(part->mNumVertices);
      for (unsigned v = 0; v < part->mNumVertices; ++v)
        vertices[v] = Eigen::Vector3f(part->mVertices[v].x, part->mVertices[v].y, part->mVertices[v].z);
      std::vector<std::array<std::uint32_t, 3>> triangles;
      for (unsigned f = 0; f < part->mNumFaces; ++f) {
        const aiFace& face = part->mFaces[f];
        if (face.mNumIndices == 3) triangles.push_back({face.mIndices[0], face.mIndices[1], face.mIndices[2]});
      }
      addWelded(mesh, welded, vertices, triangles);
    }
  }
  if (mesh.triangles.empty()) throw InputError(path.string() + ": mesh has no triangles");
  return mesh;
}

std::size_t countBorderEdges(const TriangleMesh& mesh) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> uses;
  for (const auto& t : mesh.triangles)
    for (int e = 0; e < 3; ++e) {
      std::uint32_t a = t[e], b = t[(e + 1) % 3];
      if (a > b) std::swap(a, b);
      ++uses[{a, b}];
    }
  std::size_t border = 0;
  for (const auto& [edge, count] : uses)
    if (count == 1) ++border;
  return border;
}

std::size_t fillMeshHoles(TriangleMesh& mesh, const std::string& context) {
  SurfaceMesh surface = toSurfaceMesh(mesh, context);
  std::size_t filled = 0;
  std::vector<SurfaceMesh::Halfedge_index> borders;
  PMP::extract_boundary_cycles(surface, std::back_inserter(borders));
  for (auto h : borders) {
    std::vector<SurfaceMesh::Face_index> faces;
    PMP::triangulate_hole(surface, h, std::back_inserter(faces));
    if (!faces.empty()) ++filled;
  }
  mesh = toTriangleMesh(surface);
  return filled;
}

TriangleMesh simplifyMesh(const TriangleMesh& mesh, std::size_t targetTriangles, const std::string& context) {
  if (targetTriangles == 0 || mesh.triangles.size() <= targetTriangles) return mesh;
  SurfaceMesh surface = toSurfaceMesh(mesh, context);
  // A closed triangle mesh has E = 3F/2 edges; stop below the edge count of the target.
  SMS::Count_stop_predicate<SurfaceMesh> stop(targetTriangles * 3 / 2 + 1);
  SMS::edge_collapse(surface, stop);
  surface.collect_garbage();
  return toTriangleMesh(surface);
}

// --- MeshBoundary ---------------------------------------------------------

struct MeshBoundary::Impl {
  TriangleMesh mesh;               // world coordinates, outward oriented
  std::vector<Vec3d> a, b, c;      // triangle corners (double for the winding number)
  std::vector<Vec3d> faceNormal;
  Vec3r lo = Vec3r::Zero(), hi = Vec3r::Zero();
  Vec3d boundsLo = Vec3d::Zero(), boundsHi = Vec3d::Zero();  // the same, unrounded
  // How far the vertices may move from where the grids were built (moveVertices):
  // the grids list each triangle as if it were that much larger.
  double slack = 0;
  std::vector<Eigen::Vector3f> builtVertices;
  // Uniform grid of triangles (bounding boxes) for closest-point queries.
  Vec3d origin = Vec3d::Zero();
  double cellSize = 1;
  long dims[3] = {1, 1, 1};
  std::vector<std::uint32_t> cellStart, cellTriangles;
  // The mirror queries' narrow band (TriangleBand.h), built by the first query
  // of a range; queries of another range take the general grid above.
  mutable std::mutex bandMutex;
  mutable std::unique_ptr<TriangleBand> bandOwner;
  mutable std::atomic<const TriangleBand*> band{nullptr};

  const TriangleBand* bandFor(double range) const {
    const TriangleBand* ready = band.load(std::memory_order_acquire);
    if (!ready) {
      std::lock_guard<std::mutex> lock(bandMutex);
      ready = band.load(std::memory_order_acquire);
      if (!ready) {
        bandOwner = std::make_unique<TriangleBand>(a, b, c, range, slack);
        ready = bandOwner.get();
        band.store(ready, std::memory_order_release);
      }
    }
    return ready->range() == range ? ready : nullptr;
  }

  /// Corners, face normals and bounds from mesh.vertices.
  void updateCorners() {
    const std::size_t n = mesh.triangles.size();
    a.resize(n); b.resize(n); c.resize(n); faceNormal.resize(n);
    Vec3d lo3 = Vec3d::Constant(1e300), hi3 = -lo3;
    for (std::size_t t = 0; t < n; ++t) {
      a[t] = mesh.vertices[mesh.triangles[t][0]].cast<double>();
      b[t] = mesh.vertices[mesh.triangles[t][1]].cast<double>();
      c[t] = mesh.vertices[mesh.triangles[t][2]].cast<double>();
      const Vec3d normal = (b[t] - a[t]).cross(c[t] - a[t]);
      faceNormal[t] = normal.norm() > 0 ? Vec3d(normal.normalized()) : Vec3d(Vec3d::UnitZ());
      lo3 = lo3.cwiseMin(a[t]).cwiseMin(b[t]).cwiseMin(c[t]);
      hi3 = hi3.cwiseMax(a[t]).cwiseMax(b[t]).cwiseMax(c[t]);
    }
    boundsLo = lo3;
    boundsHi = hi3;
    lo = lo3.cast<Real>();
    hi = hi3.cast<Real>();
  }

  void build() {
    const std::size_t n = mesh.triangles.size();
    updateCorners();
    builtVertices = slack > 0 ? mesh.vertices : std::vector<Eigen::Vector3f>();
    double edgeSum = 0;
    for (std::size_t t = 0; t < n; ++t)
      edgeSum += (b[t] - a[t]).norm() + (c[t] - b[t]).norm() + (a[t] - c[t]).norm();
    const Vec3d lo3 = boundsLo - Vec3d::Constant(slack), hi3 = boundsHi + Vec3d::Constant(slack);
    const Vec3d extent = hi3 - lo3;
    cellSize = std::max(2.0 * edgeSum / (3.0 * double(std::max<std::size_t>(n, 1))), extent.maxCoeff() / 64.0);
    if (!(cellSize > 0)) cellSize = 1;
    origin = lo3 - Vec3d::Constant(cellSize);
    for (int k = 0; k < 3; ++k) dims[k] = long(std::floor((hi3[k] - origin[k]) / cellSize)) + 2;
    const std::size_t cells = std::size_t(dims[0]) * dims[1] * dims[2];
    std::vector<std::vector<std::uint32_t>> lists(cells);
    for (std::size_t t = 0; t < n; ++t) {
      const Vec3d tlo = a[t].cwiseMin(b[t]).cwiseMin(c[t]) - Vec3d::Constant(slack),
                  thi = a[t].cwiseMax(b[t]).cwiseMax(c[t]) + Vec3d::Constant(slack);
      long l[3], u[3];
      for (int k = 0; k < 3; ++k) {
        l[k] = long(std::floor((tlo[k] - origin[k]) / cellSize));
        u[k] = long(std::floor((thi[k] - origin[k]) / cellSize));
      }
      for (long z = l[2]; z <= u[2]; ++z)
        for (long y = l[1]; y <= u[1]; ++y)
          for (long x = l[0]; x <= u[0]; ++x) lists[(z * dims[1] + y) * dims[0] + x].push_back(std::uint32_t(t));
    }
    cellStart.assign(cells + 1, 0);
    for (std::size_t k = 0; k < cells; ++k) cellStart[k + 1] = cellStart[k] + std::uint32_t(lists[k].size());
    cellTriangles.resize(cellStart.back());
    for (std::size_t k = 0; k < cells; ++k) std::copy(lists[k].begin(), lists[k].end(), cellTriangles.begin() + cellStart[k]);
  }

  /// Calls visit(t) for each triangle t listed in a grid cell the box [lo, hi] overlaps
  /// (a triangle in several such cells once per cell).
  template <typename F>
  void forEachTriangleNear(const Vec3d& lo, const Vec3d& hi, F&& visit) const {
    long l[3], u[3];
    for (int k = 0; k < 3; ++k) {
      l[k] = std::max(0L, long(std::floor((lo[k] - origin[k]) / cellSize)));
      u[k] = std::min(dims[k] - 1, long(std::floor((hi[k] - origin[k]) / cellSize)));
      if (l[k] > u[k]) return;
    }
    for (long z = l[2]; z <= u[2]; ++z)
      for (long y = l[1]; y <= u[1]; ++y)
        for (long x = l[0]; x <= u[0]; ++x) {
          const long cell = (z * dims[1] + y) * dims[0] + x;
          for (std::uint32_t s = cellStart[cell]; s < cellStart[cell + 1]; ++s) visit(cellTriangles[s]);
        }
  }

  /// The first triangle the segment p0 -> p1 enters through (from its outer side:
  /// direction . normal < 0), at parameter t in [0, 1] (Moeller & Trumbore 1997); -1 if none.
  long firstEntry(const Vec3d& p0, const Vec3d& p1, double& t) const {
    const Vec3d d = p1 - p0;
    long best = -1;
    t = 2;
    forEachTriangleNear(p0.cwiseMin(p1), p0.cwiseMax(p1), [&](std::uint32_t k) {
      if (d.dot(faceNormal[k]) >= 0) return;  // leaving or parallel
      const Vec3d e1 = b[k] - a[k], e2 = c[k] - a[k], h = d.cross(e2);
      const double det = e1.dot(h);
      if (det == 0) return;
      const Vec3d w = p0 - a[k];
      const double alpha = w.dot(h) / det;
      if (alpha < 0 || alpha > 1) return;
      const Vec3d q = w.cross(e1);
      const double beta = d.dot(q) / det;
      if (beta < 0 || alpha + beta > 1) return;
      const double at = e2.dot(q) / det;
      if (at < 0 || at > 1 || at > t || (at == t && long(k) > best)) return;
      t = at;
      best = long(k);
    });
    return best;
  }

  /// Closest point within maxDistance; returns the triangle index or -1.
  long closest(const Vec3d& p, double maxDistance, Vec3d& point) const {
    double best = maxDistance * maxDistance;
    long bestTriangle = -1;
    const Vec3d reach = Vec3d::Constant(maxDistance);
    forEachTriangleNear(p - reach, p + reach, [&](std::uint32_t t) {
      const Vec3d q = closestOnTriangle(p, a[t], b[t], c[t]);
      const double d2 = (q - p).squaredNorm();
      if (d2 < best || (d2 == best && bestTriangle >= 0 && long(t) < bestTriangle)) {
        best = d2;
        bestTriangle = long(t);
        point = q;
      }
    });
    return bestTriangle;
  }
};

MeshBoundary::MeshBoundary() : mImpl(std::make_unique<Impl>()) {}
MeshBoundary::~MeshBoundary() = default;

std::unique_ptr<MeshBoundary> MeshBoundary::fromMesh(TriangleMesh worldMesh, const std::string& context, double slack) {
  if (worldMesh.triangles.empty()) throw InputError(context + ": mesh has no triangles");
  std::unique_ptr<MeshBoundary> boundary(new MeshBoundary());
  worldMesh.groups.clear();
  worldMesh.normals.clear();
  boundary->mImpl->mesh = std::move(worldMesh);
  boundary->mImpl->slack = std::max(slack, 0.0);
  boundary->mImpl->build();
  return boundary;
}

void MeshBoundary::moveVertices(const std::vector<Eigen::Vector3f>& vertices) {
  Impl& m = *mImpl;
  if (vertices.size() != m.mesh.vertices.size())
    throw std::invalid_argument("MeshBoundary::moveVertices: " + std::to_string(vertices.size()) + " vertices for a mesh of " +
                                std::to_string(m.mesh.vertices.size()));
  double moved = 0;
  for (std::size_t v = 0; v < vertices.size() && !m.builtVertices.empty(); ++v)
    moved = std::max(moved, double((vertices[v] - m.builtVertices[v]).norm()));
  m.mesh.vertices = vertices;
  if (m.builtVertices.empty() || moved > m.slack) {  // beyond what the grids allow: rebuild them
    m.band.store(nullptr, std::memory_order_release);
    m.bandOwner.reset();
    m.build();
    return;
  }
  m.updateCorners();
  if (m.bandOwner) m.bandOwner->refit();
}

std::unique_ptr<MeshBoundary> MeshBoundary::load(const std::filesystem::path& path,
                                                 const MeshObstacleOptions& options, std::ostream* log) {
  const std::string context = path.string();
  TriangleMesh mesh = loadMeshFile(path);
  const std::size_t loaded = mesh.triangles.size();
  // Make it one consistently oriented surface, closed if required.
  SurfaceMesh surface = toSurfaceMesh(mesh, context);
  std::size_t holes = 0;
  if (!CGAL::is_closed(surface) && options.requireClosed) {
    std::vector<SurfaceMesh::Halfedge_index> borders;
    PMP::extract_boundary_cycles(surface, std::back_inserter(borders));
    for (auto h : borders) {
      std::vector<SurfaceMesh::Face_index> faces;
      PMP::triangulate_hole(surface, h, std::back_inserter(faces));
      if (!faces.empty()) ++holes;
    }
    // What the hole filler left (tiny cracks it cannot triangulate): close with one polygon, triangulated.
    std::vector<SurfaceMesh::Halfedge_index> left;
    PMP::extract_boundary_cycles(surface, std::back_inserter(left));
    for (auto h : left) {
      if (!surface.is_border(h)) continue;
      CGAL::Euler::fill_hole(h, surface);
      const auto face = surface.face(h);
      if (!PMP::triangulate_face(face, surface)) {
        // Degenerate polygon (a crack): fan it from one corner.
        SurfaceMesh::Halfedge_index start = surface.halfedge(face);
        while (CGAL::halfedges_around_face(start, surface).size() > 3) {
          const auto opposite = surface.next(surface.next(start));
          start = surface.next(CGAL::Euler::split_face(start, opposite, surface));
          start = surface.prev(start);
        }
      }
      ++holes;
    }
    if (!CGAL::is_closed(surface))
      throw InputError(context + ": mesh is not closed (an obstacle must bound a volume) and its holes could not be filled");
  }
  if (CGAL::is_closed(surface) && !PMP::is_outward_oriented(surface)) PMP::reverse_face_orientations(surface);
  const std::size_t closed = surface.number_of_faces();
  if (options.targetTriangles > 0 && surface.number_of_faces() > options.targetTriangles) {
    SMS::Count_stop_predicate<SurfaceMesh> stop(options.targetTriangles * 3 / 2 + 1);
    SMS::edge_collapse(surface, stop);
    surface.collect_garbage();
  }
  mesh = toTriangleMesh(surface);
  if (options.requireClosed && countBorderEdges(mesh) != 0)
    throw InputError(context + ": mesh is not closed after simplification");
  for (Eigen::Vector3f& v : mesh.vertices) v = options.transform.apply(v.cast<Real>()).cast<float>();
  if (log)
    *log << context << ": " << loaded << " triangles loaded, " << holes << " holes filled (" << closed
         << " triangles), simplified to " << mesh.triangles.size() << " triangles\n";
  return fromMesh(std::move(mesh), context);
}

void MeshBoundary::sampleSurface(Real maxGap, std::vector<Vec3r>& samples) const {
  const std::vector<Vec3r> mine = sampleTriangles(mImpl->mesh, maxGap);
  samples.insert(samples.end(), mine.begin(), mine.end());
}

void MeshBoundary::mirrorMaps(const Vec3r& x, Real range, std::uint32_t boundaryIndex,
                              std::vector<MirrorMap>& maps) const {
  const Impl& m = *mImpl;
  for (int k = 0; k < 3; ++k)
    if (x[k] < m.lo[k] - range || x[k] > m.hi[k] + range) return;
  Vec3d point;
  const Vec3d p = x.cast<double>();
  const TriangleBand* band = m.bandFor(double(range));
  const long t = band ? band->closest(p, point) : m.closest(p, double(range), point);
  if (t < 0) return;
  const Vec3d offset = p - point;
  const double distance = offset.norm();
  if (distance <= 1e-12 || offset.dot(m.faceNormal[t]) <= 0) return;  // on or behind the surface
  maps.push_back(MirrorMap::reflection(point.cast<Real>(), (offset / distance).cast<Real>(), boundaryIndex));
  maps.back().frontOnly = true;  // fluid beside a convex edge lies behind the tangent plane
}

double MeshBoundary::windingNumber(const Vec3r& x) const {
  // Sum of signed solid angles (Van Oosterom & Strackee 1983) over 4 pi.
  const Impl& m = *mImpl;
  const Vec3d p = x.cast<double>();
  double total = 0;
  for (std::size_t t = 0; t < m.a.size(); ++t) {
    const Vec3d a = m.a[t] - p, b = m.b[t] - p, c = m.c[t] - p;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    const double numerator = a.dot(b.cross(c));
    const double denominator = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    total += 2.0 * std::atan2(numerator, denominator);
  }
  return total / (4.0 * 3.14159265358979323846);
}

bool MeshBoundary::isInside(const Vec3r& x) const {
  const Impl& m = *mImpl;
  for (int k = 0; k < 3; ++k)
    if (x[k] < m.lo[k] || x[k] > m.hi[k]) return false;
  return windingNumber(x) > 0.5;
}

bool MeshBoundary::isInsideNear(const Vec3r& x, Real reach) const {
  Vec3r point, normal;
  if (!closestPoint(x, reach, point, normal)) return false;
  return (x - point).dot(normal) <= 0;  // behind (or on) its closest face
}

bool MeshBoundary::penetrated(const Vec3r& from, const Vec3r& to, Real clearance, Vec3r& exit,
                              Vec3r& normal) const {
  const Impl& m = *mImpl;
  for (int k = 0; k < 3; ++k)
    if (std::max(from[k], to[k]) < m.lo[k] || std::min(from[k], to[k]) > m.hi[k]) return false;
  // The move entered through a triangle (also through a thin part and out again).
  double entry = 0;
  if (const long k = m.firstEntry(from.cast<double>(), to.cast<double>(), entry); k >= 0 && !isInside(from)) {
    normal = m.faceNormal[k].cast<Real>();
    exit = (from.cast<double>() + entry * (to - from).cast<double>()).cast<Real>() + clearance * normal;
    if (isInside(exit)) exit = from;  // a crease: the face normal points into the solid's other side
    return true;
  }
  // Ended inside without a crossing found (through an edge or a vertex).
  for (int k = 0; k < 3; ++k)
    if (to[k] < m.lo[k] || to[k] > m.hi[k]) return false;
  Vec3d point;
  const long t = m.closest(to.cast<double>(), double((to - from).norm()), point);
  if (t < 0 || windingNumber(to) <= 0.5 || isInside(from)) return false;
  normal = m.faceNormal[t].cast<Real>();
  exit = point.cast<Real>() + clearance * normal;
  if (isInside(exit)) exit = from;  // a crease: the face normal points into the solid's other side
  return true;
}

bool MeshBoundary::escape(const Vec3r& x, Real clearance, Vec3r& exit, Vec3r& normal) const {
  Vec3r point;
  if (!isInside(x) || !closestPoint(x, Real((mImpl->hi - mImpl->lo).norm()), point, normal)) return false;
  exit = point + clearance * normal;
  return true;
}

bool MeshBoundary::closestPoint(const Vec3r& x, Real maxDistance, Vec3r& point, Vec3r& normal) const {
  Vec3d q;
  const long t = mImpl->closest(x.cast<double>(), double(maxDistance), q);
  if (t < 0) return false;
  point = q.cast<Real>();
  normal = mImpl->faceNormal[t].cast<Real>();
  return true;
}

long MeshBoundary::closestTriangle(const Vec3d& x, double maxDistance, Vec3d& point) const {
  return mImpl->closest(x, maxDistance, point);
}

TriangleMesh MeshBoundary::surfaceMesh() const {
  TriangleMesh mesh = mImpl->mesh;
  mesh.computeNormals();
  mesh.groups.assign(1, TriangleMesh::Group{name(), 0, mesh.triangles.size()});
  return mesh;
}

void MeshBoundary::bounds(Vec3r& lo, Vec3r& hi) const {
  lo = mImpl->lo;
  hi = mImpl->hi;
}

std::size_t MeshBoundary::triangleCount() const { return mImpl->mesh.triangles.size(); }
const TriangleMesh& MeshBoundary::mesh() const { return mImpl->mesh; }

} // namespace cascade
