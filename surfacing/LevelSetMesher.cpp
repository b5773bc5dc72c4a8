#include "surfacing/LevelSetMesher.h"

#include "surfacing/DualContourMesher.h"
#include "surfacing/MeshChecks.h"
#include "surfacing/MeshCleanup.h"
#include "surfacing/detail/Profile.h"

#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <unordered_map>
#include <vector>

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

/// The cell (index space, floored) of each vertex: a dual contouring vertex lies in
/// the cell of the edge crossings it was made from.
std::vector<openvdb::Coord> vertexCells(const TriangleMesh& mesh, const openvdb::math::Transform& transform) {
  std::vector<openvdb::Coord> cell(mesh.vertices.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cell.size(), 8192), [&](const auto& range) {
    for (std::size_t v = range.begin(); v != range.end(); ++v) {
      const Eigen::Vector3f& p = mesh.vertices[v];
      cell[v] = openvdb::Coord::floor(transform.worldToIndex(openvdb::Vec3d(p.x(), p.y(), p.z())));
    }
  });
  return cell;
}

openvdb::CoordBBox cellBox(const std::array<std::uint32_t, 3>& t, const std::vector<openvdb::Coord>& cell) {
  openvdb::CoordBBox box(cell[t[0]], cell[t[0]]);
  box.expand(cell[t[1]]);
  box.expand(cell[t[2]]);
  return box;
}

/// Boxes (index space) of the mesh's components no more than `extent` cells across
/// along every axis: droplets and spray, which merging would reshape (and which the
/// clean-up's volume threshold would then treat unlike the uniform mesh's).
std::vector<openvdb::CoordBBox> smallComponents(const TriangleMesh& mesh, const std::vector<openvdb::Coord>& cell,
                                                int extent) {
  const std::vector<std::uint32_t> root = componentRoots(mesh);
  std::vector<openvdb::CoordBBox> box(mesh.vertices.size());  // empty boxes, but at roots
  for (std::size_t v = 0; v < root.size(); ++v) box[root[v]].expand(cell[v]);
  std::vector<openvdb::CoordBBox> small;
  for (std::size_t v = 0; v < root.size(); ++v) {
    if (root[v] != v || box[v].empty()) continue;
    const openvdb::Coord cells = box[v].dim();
    if (cells.x() <= extent && cells.y() <= extent && cells.z() <= extent) small.push_back(box[v]);
  }
  return small;
}

/// The part of an adaptive mesh that merged cells made, and what lies around it: the
/// triangles that span more than two cells along an axis (a uniform mesh's triangle
/// joins the cells around one edge: at most two along each axis), and every triangle
/// whose cell box touches one of theirs. Its vertices are renumbered (shared ones stay
/// shared); `original` gets each triangle's index in `mesh`.
TriangleMesh mergedPart(const TriangleMesh& mesh, const std::vector<openvdb::Coord>& cell,
                        std::vector<std::size_t>& original) {
  const std::size_t n = mesh.triangles.size();
  std::vector<char> merged(n, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 8192), [&](const auto& range) {
    for (std::size_t t = range.begin(); t != range.end(); ++t) {
      const openvdb::Coord cells = cellBox(mesh.triangles[t], cell).dim();  // cells spanned, per axis
      merged[t] = cells.x() > 2 || cells.y() > 2 || cells.z() > 2;
    }
  });
  // Merged triangles by bucket of 8^3 cells (a leaf), then every triangle against them.
  const auto bucketOf = [](const openvdb::Coord& c) { return openvdb::Coord(c.x() >> 3, c.y() >> 3, c.z() >> 3); };
  std::unordered_map<openvdb::Coord, std::vector<openvdb::CoordBBox>> buckets;  // merged triangles' cell boxes
  for (std::size_t t = 0; t < n; ++t) {
    if (!merged[t]) continue;
    const openvdb::CoordBBox box = cellBox(mesh.triangles[t], cell);
    const openvdb::CoordBBox range(bucketOf(box.min()), bucketOf(box.max()));
    for (auto b = range.beginXYZ(); b; ++b) buckets[*b].push_back(box);
  }
  std::vector<char> near = merged;
  if (!buckets.empty())
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& range) {
      for (std::size_t t = range.begin(); t != range.end(); ++t) {
        if (near[t]) continue;
        const openvdb::CoordBBox box = cellBox(mesh.triangles[t], cell);
        const openvdb::CoordBBox around(bucketOf(box.min()), bucketOf(box.max()));
        for (auto b = around.beginXYZ(); b && !near[t]; ++b) {
          const auto found = buckets.find(*b);
          if (found == buckets.end()) continue;
          for (const openvdb::CoordBBox& mergedBox : found->second)
            if (box.hasOverlap(mergedBox)) {
              near[t] = 1;
              break;
            }
        }
      }
    });
  TriangleMesh part;
  original.clear();
  std::vector<std::uint32_t> index(mesh.vertices.size(), std::uint32_t(-1));
  for (std::size_t t = 0; t < n; ++t) {
    if (!near[t]) continue;
    std::array<std::uint32_t, 3> corners{};
    for (int k = 0; k < 3; ++k) {
      std::uint32_t& i = index[mesh.triangles[t][k]];
      if (i == std::uint32_t(-1)) {
        i = std::uint32_t(part.vertices.size());
        part.vertices.push_back(mesh.vertices[mesh.triangles[t][k]]);
      }
      corners[k] = i;
    }
    part.triangles.push_back(corners);
    original.push_back(t);
  }
  return part;
}

/// The cells of the uniform mesh's vertices that the adaptive mesh misses: a vertex
/// with no adaptive vertex in its cell within `tolerance` (its cell was merged) that
/// lies further than `tolerance` from the merged part. Merging around a thin spike or sheet can span it
/// with a tent of triangles that stays on the surface at its corners and centroids
/// but leaves the spike out.
std::vector<openvdb::Coord> uncoveredCells(const TriangleMesh& uniform, const std::vector<openvdb::Coord>& uniformCell,
                                           const TriangleMesh& adaptive, const std::vector<openvdb::Coord>& adaptiveCell,
                                           const TriangleMesh& merged, double tolerance) {
  std::unordered_map<openvdb::Coord, std::uint32_t> vertexOfCell;  // an unmerged cell's one vertex
  vertexOfCell.reserve(adaptive.vertices.size());
  for (std::size_t v = 0; v < adaptive.vertices.size(); ++v) vertexOfCell.emplace(adaptiveCell[v], std::uint32_t(v));
  std::vector<Eigen::Vector3f> missing;
  std::vector<openvdb::Coord> missingCell;
  for (std::size_t v = 0; v < uniform.vertices.size(); ++v) {
    const auto found = vertexOfCell.find(uniformCell[v]);
    if (found != vertexOfCell.end() &&
        (adaptive.vertices[found->second] - uniform.vertices[v]).squaredNorm() <= float(tolerance * tolerance))
      continue;  // a vertex of the adaptive mesh is that close
    missing.push_back(uniform.vertices[v]);
    missingCell.push_back(uniformCell[v]);
  }
  std::vector<openvdb::Coord> cells;
  for (std::size_t i : pointsFartherThan(missing, merged, tolerance)) cells.push_back(missingCell[i]);
  return cells;
}

} // namespace

TriangleMesh levelSetToMesh(const openvdb::FloatGrid& grid, double adaptivity) {
  if (adaptivity <= 0) return dualContourMesh(grid);
  // Components of the uniform mesh small enough to be droplets or spray are kept
  // unmerged (OpenVDB's adaptivity mask) from the start: merging would reshape them,
  // or make one vanish, and the clean-up's volume threshold would then keep a
  // different set of specks than the uniform mesh's. Merged cells that stray from the
  // surface or make the mesh cross itself are meshed again with the voxels around them
  // kept unmerged too, until none is left; after kMaxRepairs rounds, the uniform mesh.
  constexpr int kMaxRepairs = 3;
  const double dx = grid.voxelSize()[0];
  const int reach = openvdb::FloatTree::LeafNodeType::DIM / 2;  // a merged cell's reach: half a leaf
  auto mask = std::make_shared<openvdb::BoolTree>(false);
  detail::ProfileClock profile;
  TriangleMesh uniform = dualContourMesh(grid);
  const std::vector<openvdb::Coord> uniformCell = vertexCells(uniform, grid.transform());
  std::size_t droplets = 0;
  for (openvdb::CoordBBox box : smallComponents(uniform, uniformCell, 2 * reach)) {
    box.expand(1);  // the voxels at the corners of its cells, and one more
    mask->sparseFill(box, true, true);
    ++droplets;
  }
  profile.lap("adaptive: droplets");
  for (int round = 0; round <= kMaxRepairs; ++round) {
    TriangleMesh mesh = volumeToTriangles(grid, adaptivity, droplets > 0 || round > 0 ? mask : nullptr);
    profile.lap("adaptive: mesh");
    // Repairs only add triangles: a mesh that merging does not cut enough is not worth
    // its checks (a splash of droplets and thin sheets); the uniform mesh then.
    if (double(mesh.triangles.size()) * kMinimumAdaptiveCut > double(uniform.triangles.size())) {
      if (std::getenv("CASCADE_SURFACE_PROFILE"))
        std::fprintf(stderr, "  profile adaptive round %d: %zu triangles against %zu uniform: the uniform mesh\n", round,
                     mesh.triangles.size(), uniform.triangles.size());
      return uniform;
    }
    std::vector<std::size_t> bad = trianglesOffTheSurface(mesh, grid, float(kAdaptiveTolerance * dx));
    const std::size_t off = bad.size();
    const std::vector<openvdb::Coord> cell = vertexCells(mesh, grid.transform());
    std::vector<std::size_t> original;
    const TriangleMesh merged = mergedPart(mesh, cell, original);
    std::vector<std::size_t> crossing = selfIntersectingTriangles(merged);
    for (std::size_t& t : crossing) t = original[t];
    bad.insert(bad.end(), crossing.begin(), crossing.end());
    profile.lap("adaptive: off the surface, crossing");
    const std::vector<openvdb::Coord> uncovered =
        uncoveredCells(uniform, uniformCell, mesh, cell, merged, kAdaptiveTolerance * dx);
    profile.lap("adaptive: uncovered");
    // A bad triangle among unmerged voxels is the uniform mesh's own: it stays.
    std::vector<openvdb::Coord> centres;
    for (std::size_t t : bad) {
      const auto& c = mesh.triangles[t];
      const Eigen::Vector3f centroid = (mesh.vertices[c[0]] + mesh.vertices[c[1]] + mesh.vertices[c[2]]) / 3.0f;
      const openvdb::Coord centre = openvdb::Coord::floor(
          grid.transform().worldToIndex(openvdb::Vec3d(centroid.x(), centroid.y(), centroid.z())));
      if (!mask->isValueOn(centre)) centres.push_back(centre);
    }
    for (const openvdb::Coord& c : uncovered)
      if (!mask->isValueOn(c)) centres.push_back(c);
    if (std::getenv("CASCADE_SURFACE_PROFILE"))
      std::fprintf(stderr,
                   "  profile adaptive round %d: %zu triangles (%zu merged or near), %zu off, %zu crossing, %zu uncovered, "
                   "%zu droplets, %zu to repair\n",
                   round, mesh.triangles.size(), merged.triangles.size(), off, crossing.size(), uncovered.size(),
                   droplets, centres.size());
    if (centres.empty()) return mesh;
    if (round == kMaxRepairs) break;
    for (const openvdb::Coord& centre : centres)
      mask->sparseFill(openvdb::CoordBBox(centre.offsetBy(-reach), centre.offsetBy(reach)), true, true);
  }
  return uniform;
}

} // namespace cascade::surfacing
