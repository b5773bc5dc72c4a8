// Adaptive meshing (SurfaceOptions::adaptivity, OpenVDB volumeToMesh): at the default
// adaptivity, on a pool of still water, a ball, a pool with a spike and drops, and a
// pool under random spray it cuts the triangles, stays within half a voxel of the
// uniform mesh (Hausdorff distance, surfacing/MeshChecks.h), and is closed, manifold
// and free of self-intersections (CGAL) where the uniform mesh is. The estimate that
// skips adaptive meshing where it cannot pay (estimatedAdaptiveCut) bounds the cut
// VolumeToMesh makes, on a box, a ball and a cloud of drops; the cloud gets the
// uniform mesh, bit for bit.
#include "SurfacingTestUtil.h"

#include "surfacing/DualContourMesher.h"
#include "surfacing/LevelSetMesher.h"
#include "surfacing/MeshChecks.h"
#include "surfacing/MeshCleanup.h"
#include "surfacing/SurfaceStage.h"

#include <gtest/gtest.h>
#include <openvdb/tools/Composite.h>
#include <openvdb/tools/LevelSetSphere.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/VolumeToMesh.h>

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
  SurfaceOptions options;  // the default adaptivity
  SurfaceOptions uniformOptions;
  uniformOptions.adaptivity = 0;
  const SurfaceResult uniform = surfaceParticles(points, kSpacing, uniformOptions);
  const MeshTopology uniformTopology = checkMeshTopology(uniform.mesh);
  ASSERT_TRUE(uniformTopology.closed);
  ASSERT_FALSE(uniformTopology.selfIntersecting);
  ASSERT_GT(options.adaptivity, 0.0);
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

/// A level set of `voxel` voxels: a box, a ball, or a cloud of small drops (seeded).
openvdb::FloatGrid::Ptr shapeLevelSet(const std::string& shape, float voxel) {
  if (shape == "box")
    return openvdb::tools::createLevelSetBox<openvdb::FloatGrid>(
        openvdb::math::BBox<openvdb::Vec3s>(openvdb::Vec3s(0.013f, 0.021f, 0.007f), openvdb::Vec3s(0.417f, 0.259f, 0.143f)),
        *openvdb::math::Transform::createLinearTransform(voxel));
  if (shape == "ball") return openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(0.2f, openvdb::Vec3f(0.011f, 0.017f, 0.003f), voxel);
  auto cloud = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(2.5f * voxel, openvdb::Vec3f(0.0f), voxel);
  std::mt19937 random(7);
  std::uniform_real_distribution<float> at(0, 60 * voxel), radius(1.2f * voxel, 4 * voxel);
  for (int k = 0; k < 200; ++k) {
    auto drop = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(radius(random), openvdb::Vec3f(at(random), at(random), at(random)), voxel);
    openvdb::tools::csgUnion(*cloud, *drop);
  }
  return cloud;
}

class AdaptiveEstimate : public ::testing::TestWithParam<const char*> {};

TEST_P(AdaptiveEstimate, BoundsTheCutOfVolumeToMesh) {
  const float voxel = 0.005f;
  const openvdb::FloatGrid::Ptr grid = shapeLevelSet(GetParam(), voxel);
  const TriangleMesh uniform = dualContourMesh(*grid);
  const double adaptivity = SurfaceOptions().adaptivity;
  const double estimate = estimatedAdaptiveCut(uniform, *grid, adaptivity);
  openvdb::tools::VolumeToMesh mesher(0.0, adaptivity);
  mesher(*grid);
  const double cut = double(uniform.vertices.size()) / double(mesher.pointListSize());
  std::printf("%s: %zu uniform vertices, %zu adaptive: %.2fx fewer, estimated at most %.2fx\n", GetParam(),
              uniform.vertices.size(), mesher.pointListSize(), cut, estimate);
  EXPECT_GE(estimate, cut);
  EXPECT_LT(estimate, 1.5 * cut);  // and close enough to decide on
  if (std::string(GetParam()) == "cloud") {
    // Nothing flat: no adaptive meshing, the uniform mesh itself.
    EXPECT_LT(estimate, kMinimumAdaptiveCut);
    const TriangleMesh mesh = levelSetToMesh(*grid, adaptivity);
    EXPECT_EQ(mesh.vertices, uniform.vertices);
    EXPECT_EQ(mesh.triangles, uniform.triangles);
  } else {
    EXPECT_GT(estimate, 3.0);
  }
}

INSTANTIATE_TEST_SUITE_P(Shapes, AdaptiveEstimate, ::testing::Values("box", "ball", "cloud"),
                         [](const auto& info) { return std::string(info.param); });

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
