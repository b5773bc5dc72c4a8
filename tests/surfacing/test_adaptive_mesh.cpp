// Adaptive meshing (SurfaceOptions::adaptivity, OpenVDB volumeToMesh): on a pool
// of still water, a ball, a pool with a spike and drops, and a pool under random
// spray it cuts the triangles, stays within half a voxel
// of the uniform mesh (Hausdorff distance, surfacing/MeshChecks.h), and is closed,
// manifold and free of self-intersections (CGAL) where the uniform mesh is.
#include "SurfacingTestUtil.h"

#include "surfacing/MeshChecks.h"
#include "surfacing/MeshCleanup.h"
#include "surfacing/SurfaceStage.h"

#include <gtest/gtest.h>

#include <random>

using namespace cascade;
using namespace cascade::surfacing;

namespace {

constexpr double kSpacing = 0.02;

struct AdaptiveCase {
  const char* name;
  std::vector<Vec3r> (*points)();
  double minimumCut;  // uniform triangles / adaptive triangles
};

void PrintTo(const AdaptiveCase& c, std::ostream* os) { *os << c.name; }

std::vector<Vec3r> pool() { return test::latticeBlock(Vec3d(0, 0, 0), 40, 30, 8, kSpacing, 0.05 * kSpacing); }
/// A pool with spray: a thin spike (one particle across, 6 high) rising from it, and
/// single drops above it. Merging the flat water around the spike's foot may span it
/// with a tent of triangles; the drops must come out as the uniform mesh makes them.
std::vector<Vec3r> poolWithSpray() {
  std::vector<Vec3r> points = pool();
  const double top = 7 * kSpacing;
  for (int k = 1; k <= 6; ++k) points.emplace_back(Real(20.3 * kSpacing), Real(15.2 * kSpacing), Real(top + k * kSpacing));
  for (int d = 0; d < 12; ++d)
    points.emplace_back(Real((3.1 + 3 * d) * kSpacing), Real((4.3 + 2 * d) * kSpacing), Real(top + (3.5 + 0.25 * d) * kSpacing));
  return points;
}
/// The same pool under random spray: 150 particles scattered just above it (seeded),
/// touching the water and each other by chance: drops, pairs, necks and bumps.
std::vector<Vec3r> poolUnderRandomSpray() {
  std::vector<Vec3r> points = pool();
  std::mt19937 random(2026);
  std::uniform_real_distribution<double> x(1 * kSpacing, 39 * kSpacing), y(1 * kSpacing, 29 * kSpacing),
      z(7.6 * kSpacing, 10 * kSpacing);
  for (int k = 0; k < 150; ++k) points.emplace_back(Real(x(random)), Real(y(random)), Real(z(random)));
  return points;
}
std::vector<Vec3r> ball() { return test::latticeBall(Vec3d(0.3, 0.2, 0.1), 10 * kSpacing, kSpacing, 0.05 * kSpacing); }

class AdaptiveMesh : public ::testing::TestWithParam<AdaptiveCase> {};

TEST_P(AdaptiveMesh, FewerTrianglesWithinHalfAVoxelClosedAndNotSelfIntersecting) {
  const std::vector<Vec3r> points = GetParam().points();
  SurfaceOptions options;
  const SurfaceResult uniform = surfaceParticles(points, kSpacing, options);
  const MeshTopology uniformTopology = checkMeshTopology(uniform.mesh);
  ASSERT_TRUE(uniformTopology.closed);
  ASSERT_FALSE(uniformTopology.selfIntersecting);
  options.adaptivity = 0.1;
  const SurfaceResult adaptive = surfaceParticles(points, kSpacing, options);
  const MeshTopology topology = checkMeshTopology(adaptive.mesh);
  const double cut = double(uniform.mesh.triangles.size()) / double(adaptive.mesh.triangles.size());
  const double distance = hausdorffDistance(adaptive.mesh, uniform.mesh) / uniform.voxelSize;
  std::printf("%s: %zu -> %zu triangles (%.2fx fewer), Hausdorff distance %.3f voxels\n", GetParam().name,
              uniform.mesh.triangles.size(), adaptive.mesh.triangles.size(), cut, distance);
  EXPECT_EQ(topology.rejectedFaces, 0u);
  EXPECT_TRUE(topology.closed);
  EXPECT_FALSE(topology.selfIntersecting);
  EXPECT_GE(cut, GetParam().minimumCut);
  EXPECT_LE(distance, 0.5);
  // The adaptive mesh keeps the volume (divergence theorem, MeshCleanup.h).
  EXPECT_NEAR(meshVolume(adaptive.mesh), meshVolume(uniform.mesh), 0.01 * meshVolume(uniform.mesh));
}

INSTANTIATE_TEST_SUITE_P(Shapes, AdaptiveMesh,
                         ::testing::Values(AdaptiveCase{"pool", &pool, 3.0}, AdaptiveCase{"ball", &ball, 2.5},
                                           AdaptiveCase{"pool_with_spray", &poolWithSpray, 2.5},
                                           AdaptiveCase{"pool_under_random_spray", &poolUnderRandomSpray, 1.8}),
                         [](const auto& info) { return std::string(info.param.name); });

TEST(MeshChecks, HausdorffDistanceOfAShiftedMeshIsTheShift) {
  const auto points = test::latticeBall(Vec3d(0, 0, 0), 6 * kSpacing, kSpacing);
  const TriangleMesh mesh = surfaceParticles(points, kSpacing, SurfaceOptions{}).mesh;
  TriangleMesh shifted = mesh;
  for (auto& v : shifted.vertices) v.z() += 0.003f;
  // A ball moved along z: the largest distance is at its poles, the shift itself.
  EXPECT_NEAR(hausdorffDistance(mesh, shifted), 0.003, 0.0003);
  EXPECT_LT(hausdorffDistance(mesh, mesh), 1e-6);
  TriangleMesh open = mesh;
  open.triangles.pop_back();
  EXPECT_FALSE(checkMeshTopology(open).closed);
  EXPECT_TRUE(checkMeshTopology(mesh).closed);
}

} // namespace
