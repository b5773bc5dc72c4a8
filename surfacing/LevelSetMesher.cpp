#include "surfacing/LevelSetMesher.h"

#include "surfacing/DualContourMesher.h"

#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/parallel_for.h>

namespace cascade::surfacing {

TriangleMesh levelSetToMesh(const openvdb::FloatGrid& grid, double adaptivity) {
  if (adaptivity <= 0) return dualContourMesh(grid);

  std::vector<openvdb::Vec3s> points;
  std::vector<openvdb::Vec3I> triangles;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(grid, points, triangles, quads, 0.0, adaptivity, true);

  TriangleMesh mesh;
  mesh.vertices.resize(points.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 8192), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i)
      mesh.vertices[i] = Eigen::Vector3f(points[i].x(), points[i].y(), points[i].z());
  });
  mesh.triangles.resize(triangles.size() + 2 * quads.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, triangles.size(), 8192), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i)
      mesh.triangles[i] = {triangles[i][0], triangles[i][1], triangles[i][2]};
  });
  const std::size_t base = triangles.size();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, quads.size(), 8192), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const openvdb::Vec4I& q = quads[i];
      const Eigen::Vector3f& a = mesh.vertices[q[0]];
      const Eigen::Vector3f& b = mesh.vertices[q[1]];
      const Eigen::Vector3f& c = mesh.vertices[q[2]];
      const Eigen::Vector3f& d = mesh.vertices[q[3]];
      if ((a - c).squaredNorm() <= (b - d).squaredNorm()) {  // shorter diagonal
        mesh.triangles[base + 2 * i] = {q[0], q[1], q[2]};
        mesh.triangles[base + 2 * i + 1] = {q[0], q[2], q[3]};
      } else {
        mesh.triangles[base + 2 * i] = {q[0], q[1], q[3]};
        mesh.triangles[base + 2 * i + 1] = {q[1], q[2], q[3]};
      }
    }
  });
  return mesh;
}

} // namespace cascade::surfacing
