// Meshes from surfaceParticles(): a ball of particles gives a closed, manifold,
// outward-oriented mesh with the ball's volume and area (checked with CGAL PMP);
// OBJ and VDB files round-trip; the lattice is world aligned.
#include "SurfacingTestUtil.h"

#include "libsph/Errors.h"
#include "libsph/io/TriangleMesh.h"
#include "surfacing/MeshCleanup.h"
#include "surfacing/SurfaceStage.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Surface_mesh.h>
#include <gtest/gtest.h>
#include <openvdb/io/File.h>

#include <filesystem>
#include <fstream>

using namespace cascade;
namespace PMP = CGAL::Polygon_mesh_processing;
namespace fs = std::filesystem;

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Mesh = CGAL::Surface_mesh<Kernel::Point_3>;

constexpr double kSpacing = 0.02;

fs::path scratchDir(const std::string& name) {
  const fs::path dir = fs::path(CASCADE_BINARY_DIR) / "test_scratch" / ("surfacing_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

struct BallCase {
  SurfaceMethod method;
  double tolerance;  // relative, on volume and area
};

void PrintTo(const BallCase& c, std::ostream* os) { *os << surfaceMethodName(c.method); }

class BallMeshTest : public ::testing::TestWithParam<BallCase> {};

TEST_P(BallMeshTest, ClosedOutwardManifoldWithBallVolumeAndArea) {
  const auto points = test::latticeBall(Vec3d(0.3, 0.2, 0.1), 10 * kSpacing, kSpacing, 0.05 * kSpacing);
  const double volume = points.size() * std::pow(kSpacing, 3);
  const double radius = std::cbrt(3 * volume / (4 * M_PI));
  SurfaceOptions options;
  options.method = GetParam().method;
  const SurfaceResult result = surfaceParticles(points, kSpacing, options);
  const TriangleMesh& mesh = result.mesh;
  ASSERT_GT(mesh.triangles.size(), 1000u);
  ASSERT_EQ(mesh.normals.size(), mesh.vertices.size());

  std::vector<Kernel::Point_3> soupPoints;
  for (const auto& v : mesh.vertices) soupPoints.emplace_back(v.x(), v.y(), v.z());
  std::vector<std::vector<std::size_t>> soupFaces;
  for (const auto& t : mesh.triangles) soupFaces.push_back({t[0], t[1], t[2]});
  ASSERT_TRUE(PMP::is_polygon_soup_a_polygon_mesh(soupFaces)) << "not an oriented 2-manifold";
  Mesh cgalMesh;
  PMP::polygon_soup_to_polygon_mesh(soupPoints, soupFaces, cgalMesh);
  EXPECT_TRUE(CGAL::is_closed(cgalMesh));
  EXPECT_TRUE(PMP::is_outward_oriented(cgalMesh));
  const double meshVolume = PMP::volume(cgalMesh), meshArea = PMP::area(cgalMesh);
  const double area = 4 * M_PI * radius * radius;
  std::printf("%s: volume %.4g vs %.4g (%.2f%%), area %.4g vs %.4g (%.2f%%), %zu triangles\n",
              surfaceMethodName(GetParam().method).c_str(), meshVolume, volume,
              100 * (meshVolume / volume - 1), meshArea, area, 100 * (meshArea / area - 1),
              mesh.triangles.size());
  EXPECT_NEAR(meshVolume / volume, 1.0, GetParam().tolerance);
  EXPECT_NEAR(meshArea / area, 1.0, GetParam().tolerance);
  // Normals point away from the centre.
  std::size_t outward = 0;
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
    if (mesh.normals[i].dot(mesh.vertices[i] - Eigen::Vector3f(0.3f, 0.2f, 0.1f)) > 0) ++outward;
  EXPECT_EQ(outward, mesh.vertices.size());
}

INSTANTIATE_TEST_SUITE_P(Methods, BallMeshTest,
                         ::testing::Values(BallCase{SurfaceMethod::AnisotropicKernels, 0.04},
                                           BallCase{SurfaceMethod::SmoothSpheres, 0.04},
                                           BallCase{SurfaceMethod::UnionOfSpheres, 0.25}),
                         [](const auto& info) { return surfaceMethodName(info.param.method); });

TEST(SurfaceMesh, TriangleBudgetAndRemeshKeepTheBall) {
  const auto points = test::latticeBall(Vec3d(0, 0, 0), 8 * kSpacing, kSpacing);
  const double volume = points.size() * std::pow(kSpacing, 3);
  SurfaceOptions options;
  options.adaptivity = 0;  // the uniform mesh, decimated and remeshed
  const SurfaceResult full = surfaceParticles(points, kSpacing, options);
  options.triangleBudget = 2000;
  const SurfaceResult decimated = surfaceParticles(points, kSpacing, options);
  std::printf("budget: %zu -> %zu triangles, volume %.4g vs %.4g\n", full.mesh.triangles.size(),
              decimated.mesh.triangles.size(), surfacing::meshVolume(decimated.mesh), volume);
  EXPECT_GT(full.mesh.triangles.size(), 4000u);
  EXPECT_LE(decimated.mesh.triangles.size(), 2000u);
  EXPECT_GE(decimated.mesh.triangles.size(), 1800u);
  EXPECT_NEAR(surfacing::meshVolume(decimated.mesh) / volume, 1.0, 0.05);
  options.triangleBudget = 0;
  options.remeshEdgeLength = 2 * kSpacing;
  const SurfaceResult remeshed = surfaceParticles(points, kSpacing, options);
  std::printf("remesh: %zu triangles, volume %.4g\n", remeshed.mesh.triangles.size(),
              surfacing::meshVolume(remeshed.mesh));
  EXPECT_LT(remeshed.mesh.triangles.size(), full.mesh.triangles.size() / 4);
  EXPECT_NEAR(surfacing::meshVolume(remeshed.mesh) / volume, 1.0, 0.05);
}

/// The largest distance from a vertex of `moved` less `shift` to its nearest vertex of
/// `mesh` (vertex order follows the tree's traversal).
double worstShiftError(const TriangleMesh& mesh, const TriangleMesh& moved, const Vec3r& shift) {
  double worst = 0;
  for (const Eigen::Vector3f& v : moved.vertices) {
    double best = 1e9;
    for (const Eigen::Vector3f& w : mesh.vertices) best = std::min(best, double((v - w - shift).norm()));
    worst = std::max(worst, best);
  }
  return worst;
}

class WorldAligned : public ::testing::TestWithParam<double> {};

TEST_P(WorldAligned, DeterministicAndMovedByWholeVoxelsOrLeavesExactly) {
  const auto points = test::latticeBall(Vec3d(0.0, 0.0, 0.0), 6 * kSpacing, kSpacing, 0.1 * kSpacing);
  SurfaceOptions options;
  options.adaptivity = GetParam();
  const SurfaceResult first = surfaceParticles(points, kSpacing, options);
  const SurfaceResult second = surfaceParticles(points, kSpacing, options);
  ASSERT_EQ(first.mesh.vertices, second.mesh.vertices);
  ASSERT_EQ(first.mesh.triangles, second.mesh.triangles);
  // Moving the particles by whole voxels moves the uniform mesh by exactly as much:
  // the lattice is the world's, so frames do not shimmer. Adaptive meshes merge
  // blocks of the tree's leaves (8 voxels, world aligned too): whole leaves then.
  const double voxel = first.voxelSize;
  const Vec3r shift = (options.adaptivity > 0 ? Vec3r(8, -16, 24) : Vec3r(7, -3, 12)) * Real(voxel);
  std::vector<Vec3r> moved = points;
  for (auto& p : moved) p += shift;
  const SurfaceResult shifted = surfaceParticles(moved, kSpacing, options);
  ASSERT_EQ(shifted.mesh.vertices.size(), first.mesh.vertices.size());
  ASSERT_EQ(shifted.mesh.triangles.size(), first.mesh.triangles.size());
  EXPECT_LT(worstShiftError(first.mesh, shifted.mesh, shift), 1e-3 * voxel);
}

INSTANTIATE_TEST_SUITE_P(SurfaceMesh, WorldAligned, ::testing::Values(0.0, SurfaceOptions().adaptivity),
                         [](const auto& info) { return info.param > 0 ? std::string("adaptive") : std::string("uniform"); });

TEST(SurfaceMesh, ObjRoundTripYUp) {
  const auto points = test::latticeBall(Vec3d(0.1, 0.2, 0.3), 5 * kSpacing, kSpacing);
  const SurfaceResult result = surfaceParticles(points, kSpacing, SurfaceOptions{});
  const fs::path dir = scratchDir("obj");
  for (bool yUp : {false, true}) {
    const fs::path path = dir / (yUp ? "yup.obj" : "zup.obj");
    writeSurfaceMesh(path, result.mesh, yUp);
    const TriangleMesh back = readObj(path);
    {  // the axes are named in the header, for Cascade's render and for people
      std::ifstream in(path);
      std::string first, second;
      std::getline(in, first);
      std::getline(in, second);
      EXPECT_EQ(second.rfind(yUp ? "# up: y" : "# up: z", 0), 0u) << second;
    }
    ASSERT_EQ(back.vertices.size(), result.mesh.vertices.size());
    ASSERT_EQ(back.normals.size(), result.mesh.normals.size());
    ASSERT_EQ(back.triangles, result.mesh.triangles);
    double worst = 0;
    for (std::size_t i = 0; i < back.vertices.size(); ++i) {
      const Eigen::Vector3f& v = result.mesh.vertices[i];
      // y-up files hold (x, z, -y); a y-up importer maps them back to (x, y, z).
      const Eigen::Vector3f expected = yUp ? Eigen::Vector3f(v.x(), v.z(), -v.y()) : v;
      worst = std::max(worst, double((back.vertices[i] - expected).norm()));
    }
    EXPECT_LT(worst, 1e-6);
    EXPECT_NEAR(std::abs(surfacing::meshVolume(back)), std::abs(surfacing::meshVolume(result.mesh)), 1e-9);
    EXPECT_GT(surfacing::meshVolume(back), 0);  // rotations keep the outward orientation
  }
}

// leastSurfaceBytes is a lower bound (a frame refused for it could never have fitted):
// a ball, the shape with the least surface, takes at least that many band voxels, and
// a flat slab of the same particles takes more.
TEST(SurfaceMesh, TheLeastMemoryBoundsTheLevelSetFromBelow) {
  const auto ball = test::latticeBall(Vec3d(0, 0, 0), 8 * kSpacing, kSpacing);
  SurfaceOptions options;
  options.velocity = false;
  const SurfaceResult result = surfaceParticles(ball, kSpacing, options);
  const double least = leastSurfaceBytes(ball.size(), kSpacing, 0.5 * kSpacing, false);
  EXPECT_GT(least, 0);
  EXPECT_LE(least, 4.0 * double(result.activeVoxels));
  EXPECT_GT(least, 0.25 * 4.0 * double(result.activeVoxels));  // and not a useless bound
  std::vector<Vec3r> slab;
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j)
      for (int k = 0; k < 2 && slab.size() < ball.size(); ++k)
        slab.emplace_back(Real(i * kSpacing), Real(j * kSpacing), Real(k * kSpacing));
  const SurfaceResult flat = surfaceParticles(slab, kSpacing, options);
  EXPECT_LE(leastSurfaceBytes(slab.size(), kSpacing, 0.5 * kSpacing, false),
            4.0 * double(flat.activeVoxels));
  // A voxel size far too small for the machine is refused before anything is allocated.
  SurfaceOptions tiny = options;
  tiny.voxelSize = 1e-9;
  EXPECT_THROW(surfaceParticles(ball, kSpacing, tiny), InputError);
}

TEST(SurfaceMesh, VdbRoundTrip) {
  const Vec3d center(0.1, 0.2, 0.3);
  const auto points = test::latticeBall(center, 8 * kSpacing, kSpacing);
  const double radius = std::cbrt(3.0 * points.size() * std::pow(kSpacing, 3) / (4 * M_PI));
  const fs::path path = scratchDir("vdb") / "surface.vdb";
  SurfaceOptions options;
  options.writeDensity = true;
  const SurfaceResult result = surfaceParticles(points, kSpacing, options, path);

  openvdb::io::File file(path.string());
  file.open();
  auto surface = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("surface"));
  auto density = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("density"));
  file.close();
  ASSERT_TRUE(surface);
  ASSERT_TRUE(density);
  EXPECT_EQ(surface->getGridClass(), openvdb::GRID_LEVEL_SET);
  EXPECT_EQ(density->getGridClass(), openvdb::GRID_FOG_VOLUME);
  EXPECT_DOUBLE_EQ(surface->voxelSize()[0], 0.5 * kSpacing);
  EXPECT_EQ(surface->activeVoxelCount(), result.activeVoxels);
  EXPECT_NEAR(surface->background(), 3 * 0.5 * kSpacing, 1e-7);
  // The zero crossing is where it was in memory: at the ball's radius.
  const double r = test::zeroCrossing(*surface, center, Vec3d(0, 0, 1), 2 * radius);
  EXPECT_NEAR(r, radius, 0.25 * kSpacing);
  // The fog is 1 deep inside, 0 outside.
  const auto inside = density->getConstAccessor().getValue(
      surface->transform().worldToIndexCellCentered(openvdb::Vec3d(center.x(), center.y(), center.z())));
  EXPECT_FLOAT_EQ(inside, 1.0f);
  EXPECT_FLOAT_EQ(density->background(), 0.0f);
}

} // namespace

namespace {

/// Every active voxel of `a` has the same value in `b` and the active counts agree.
std::size_t differingVoxels(const openvdb::FloatGrid& a, const openvdb::FloatGrid& b) {
  std::size_t differing = a.activeVoxelCount() == b.activeVoxelCount() ? 0 : 1;
  const auto accessor = b.getConstAccessor();
  for (auto it = a.tree().cbeginValueOn(); it; ++it)
    if (!accessor.isValueOn(it.getCoord()) || accessor.getValue(it.getCoord()) != *it) ++differing;
  return differing;
}

} // namespace

// The default VDB (active-mask compression only) and the --vdb-blosc one hold the
// same voxels bit for bit; Blosc only changes the encoding.
TEST(SurfaceMesh, VdbWithAndWithoutBloscHoldTheSameVoxels) {
  const auto points = test::latticeBall(Vec3d(0.1, 0.2, 0.3), 8 * kSpacing, kSpacing);
  const fs::path dir = scratchDir("vdb_blosc");
  SurfaceOptions options;
  surfaceParticles(points, kSpacing, options, dir / "plain.vdb");
  options.vdbBlosc = true;
  surfaceParticles(points, kSpacing, options, dir / "blosc.vdb");
  auto read = [](const fs::path& path) {
    openvdb::io::File file(path.string());
    file.open();
    auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("surface"));
    file.close();
    return grid;
  };
  const auto plain = read(dir / "plain.vdb"), blosc = read(dir / "blosc.vdb");
  ASSERT_TRUE(plain && blosc);
  EXPECT_GT(plain->activeVoxelCount(), 1000u);
  EXPECT_EQ(differingVoxels(*plain, *blosc), 0u);
  EXPECT_EQ(differingVoxels(*blosc, *plain), 0u);
}
