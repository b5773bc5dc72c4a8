#include "surfacing/LevelSetMesher.h"

#include "surfacing/DualContourMesher.h"
#include "surfacing/MeshChecks.h"

#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <cstdio>
#include <cstdlib>

namespace cascade::surfacing {

namespace {

/// OpenVDB's adaptive mesh of `grid`, its quads split along the shorter diagonal;
/// voxels of `mask` (may be null) are not merged.
TriangleMesh volumeToTriangles(const openvdb::FloatGrid& grid, double adaptivity,
                               const openvdb::BoolTree::Ptr& mask) {
  openvdb::tools::VolumeToMesh mesher(0.0, adaptivity, true);
  if (mask) mesher.setAdaptivityMask(mask);
  mesher(grid);
  TriangleMesh mesh;
  mesh.vertices.resize(mesher.pointListSize());
  const openvdb::Vec3s* points = mesher.pointList().get();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mesh.vertices.size(), 8192), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i)
      mesh.vertices[i] = Eigen::Vector3f(points[i].x(), points[i].y(), points[i].z());
  });
  for (std::size_t n = 0; n < mesher.polygonPoolListSize(); ++n) {
    const openvdb::tools::PolygonPool& pool = mesher.polygonPoolList()[n];
    for (std::size_t i = 0; i < pool.numTriangles(); ++i) {
      const openvdb::Vec3I& t = pool.triangle(i);
      mesh.triangles.push_back({t[0], t[1], t[2]});
    }
    for (std::size_t i = 0; i < pool.numQuads(); ++i) {
      const openvdb::Vec4I& q = pool.quad(i);
      const Eigen::Vector3f& a = mesh.vertices[q[0]];
      const Eigen::Vector3f& b = mesh.vertices[q[1]];
      const Eigen::Vector3f& c = mesh.vertices[q[2]];
      const Eigen::Vector3f& d = mesh.vertices[q[3]];
      if ((a - c).squaredNorm() <= (b - d).squaredNorm()) {  // shorter diagonal
        mesh.triangles.push_back({q[0], q[1], q[2]});
        mesh.triangles.push_back({q[0], q[2], q[3]});
      } else {
        mesh.triangles.push_back({q[0], q[1], q[3]});
        mesh.triangles.push_back({q[1], q[2], q[3]});
      }
    }
  }
  return mesh;
}

/// Triangles of `mesh` whose centroid or a corner lies further than `tolerance`
/// (m) from the zero crossing of the level set (|phi| there, trilinear).
std::vector<std::size_t> trianglesOffTheSurface(const TriangleMesh& mesh, const openvdb::FloatGrid& grid,
                                                float tolerance) {
  tbb::enumerable_thread_specific<std::vector<std::size_t>> found;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mesh.triangles.size(), 4096), [&](const auto& range) {
    openvdb::tools::GridSampler<openvdb::FloatGrid::ConstAccessor, openvdb::tools::BoxSampler> phi(
        grid.getConstAccessor(), grid.transform());
    auto off = [&](const Eigen::Vector3f& p) {
      return std::abs(phi.wsSample(openvdb::Vec3d(p.x(), p.y(), p.z()))) > tolerance;
    };
    for (std::size_t t = range.begin(); t != range.end(); ++t) {
      const auto& c = mesh.triangles[t];
      const Eigen::Vector3f& a = mesh.vertices[c[0]];
      const Eigen::Vector3f& b = mesh.vertices[c[1]];
      const Eigen::Vector3f& d = mesh.vertices[c[2]];
      if (off((a + b + d) / 3.0f) || off(a) || off(b) || off(d)) found.local().push_back(t);
    }
  });
  std::vector<std::size_t> result;
  for (const auto& local : found) result.insert(result.end(), local.begin(), local.end());
  return result;
}

} // namespace

TriangleMesh levelSetToMesh(const openvdb::FloatGrid& grid, double adaptivity) {
  if (adaptivity <= 0) return dualContourMesh(grid);
  // Merged cells that stray from the surface or make the mesh cross itself are
  // meshed again with the voxels around them kept unmerged (OpenVDB's adaptivity
  // mask), until none is left; after kMaxRepairs rounds, the uniform mesh.
  constexpr int kMaxRepairs = 3;
  const double dx = grid.voxelSize()[0];
  auto mask = std::make_shared<openvdb::BoolTree>(false);
  for (int round = 0; round <= kMaxRepairs; ++round) {
    TriangleMesh mesh = volumeToTriangles(grid, adaptivity, round > 0 ? mask : nullptr);
    std::vector<std::size_t> bad = trianglesOffTheSurface(mesh, grid, float(kAdaptiveTolerance * dx));
    const std::vector<std::size_t> crossing = selfIntersectingTriangles(mesh);
    bad.insert(bad.end(), crossing.begin(), crossing.end());
    // A bad triangle among unmerged voxels is the uniform mesh's own: it stays.
    std::vector<openvdb::Coord> centres;
    for (std::size_t t : bad) {
      const auto& c = mesh.triangles[t];
      const Eigen::Vector3f centroid = (mesh.vertices[c[0]] + mesh.vertices[c[1]] + mesh.vertices[c[2]]) / 3.0f;
      const openvdb::Coord centre = openvdb::Coord::floor(
          grid.transform().worldToIndex(openvdb::Vec3d(centroid.x(), centroid.y(), centroid.z())));
      if (!mask->isValueOn(centre)) centres.push_back(centre);
    }
    if (std::getenv("CASCADE_SURFACE_PROFILE"))
      std::fprintf(stderr, "  profile adaptive round %d: %zu triangles, %zu off, %zu crossing, %zu to repair\n", round,
                   mesh.triangles.size(), bad.size() - crossing.size(), crossing.size(), centres.size());
    if (centres.empty()) return mesh;
    if (round == kMaxRepairs) break;
    // Keep unmerged every voxel within a merged cell's reach (half a leaf) of a bad triangle.
    const int reach = openvdb::FloatTree::LeafNodeType::DIM / 2;
    for (const openvdb::Coord& centre : centres)
      mask->sparseFill(openvdb::CoordBBox(centre.offsetBy(-reach), centre.offsetBy(reach)), true, true);
  }
  return dualContourMesh(grid);
}

} // namespace cascade::surfacing
