// The "v" grid for motion blur (surfacing/detail/BandVelocity.h): particle
// velocities over the level set's narrow band with the method's kernel weights.
// A block moving as a whole gives its velocity everywhere in the band; a block
// turning about an axis gives omega x r; mesh vertices carry the grid's velocity;
// surface.NNNN.vdb holds "v" (world space) and fluid.NNNN.ply its vertex velocities.
#include "SurfacingTestUtil.h"

#include "libsph/io/TriangleMesh.h"
#include "surfacing/LevelSetMethods.h"
#include "surfacing/SurfaceStage.h"
#include "surfacing/detail/BandVelocity.h"

#include <openvdb/io/File.h>
#include <gtest/gtest.h>

#include <openvdb/tools/LevelSetSphere.h>

#include <filesystem>
#include <random>
#include <set>

using namespace cascade;
using namespace cascade::surfacing;
namespace fs = std::filesystem;

namespace {

constexpr double kSpacing = 0.02;
/// How far the velocity at the surface may come from: 1.5 spacings (the surface
/// lies half a spacing outside the outer particles, which carry their own velocity).
constexpr double kSurfaceReach = 1.5 * kSpacing;
/// The widest kernel support: 2 spacings, stretched up to 2x (AnisotropicKernelSettings).
constexpr double kKernelReach = 4 * kSpacing;

struct Made {
  openvdb::FloatGrid::Ptr surface;
  openvdb::Vec3SGrid::Ptr velocity;
};

Made withVelocity(SurfaceMethod method, const std::vector<Vec3r>& points, const std::vector<Vec3r>& velocities) {
  openvdb::initialize();
  LevelSetSettings settings;
  settings.spacing = kSpacing;
  settings.voxelSize = 0.5 * kSpacing;
  settings.velocities = &velocities;
  ParticleLevelSet made = particlesToLevelSet(method, points, settings);
  if (!made.velocity) return {made.surface, nullptr};
  return {made.surface, velocityOverBand(*made.surface, std::move(made.velocity), settings.halfWidth)};
}

class VelocityGrid : public ::testing::TestWithParam<SurfaceMethod> {};

TEST_P(VelocityGrid, ATranslatingBlockHasItsVelocityEverywhereInTheBand) {
  const auto points = test::latticeBlock(Vec3d(0.1, -0.2, 0.3), 12, 9, 7, kSpacing, 0.1 * kSpacing);
  const Vec3r u(1.5, -0.7, 2.25);
  const Made made = withVelocity(GetParam(), points, std::vector<Vec3r>(points.size(), u));
  ASSERT_TRUE(made.velocity);
  EXPECT_EQ(made.velocity->getName(), "v");
  EXPECT_TRUE(made.velocity->isInWorldSpace());
  // "v" covers exactly the band's voxels.
  for (auto voxel = made.surface->cbeginValueOn(); voxel; ++voxel)
    ASSERT_TRUE(made.velocity->tree().isValueOn(voxel.getCoord()));
  EXPECT_EQ(made.velocity->activeVoxelCount(), made.surface->activeVoxelCount());
  double worst = 0;
  for (auto v = made.velocity->cbeginValueOn(); v; ++v)
    worst = std::max(worst, double((Vec3r(v->x(), v->y(), v->z()) - u).norm() / u.norm()));
  EXPECT_GT(made.velocity->activeVoxelCount(), 5000u);
  EXPECT_LT(worst, 0.01) << made.velocity->activeVoxelCount() << " voxels";
}

TEST_P(VelocityGrid, ARotatingBlockGivesOmegaCrossR) {
  // A 0.24 m block whose centre is 1 m from the axis, turning at 2 rad/s about z.
  const Vec3d corner(0.88, -0.12, 0.0);
  const auto points = test::latticeBlock(corner, 12, 12, 12, kSpacing, 0.1 * kSpacing);
  const Vec3r omega(0, 0, 2);
  std::vector<Vec3r> velocities;
  for (const Vec3r& p : points) velocities.push_back(omega.cross(p));
  const Made made = withVelocity(GetParam(), points, velocities);
  ASSERT_TRUE(made.velocity);
  auto exactAt = [&](const openvdb::Vec3d& x) { return omega.cross(Vec3r(Real(x.x()), Real(x.y()), Real(x.z()))); };
  auto errorAt = [&](const openvdb::Vec3d& x, const openvdb::Vec3s& v) {
    return double((Vec3r(v.x(), v.y(), v.z()) - exactAt(x)).norm() / exactAt(x).norm());
  };
  // Inside the water's half of the band: the kernel-weighted mean of omega x r.
  double worstInside = 0, worstOutside = 0;
  auto access = made.velocity->getConstAccessor();
  auto phi = made.surface->getConstAccessor();
  for (auto voxel = made.velocity->cbeginValueOn(); voxel; ++voxel) {
    const openvdb::Vec3d x = made.velocity->indexToWorld(voxel.getCoord());
    const double error = errorAt(x, *voxel);
    if (phi.getValue(voxel.getCoord()) <= 0) {
      worstInside = std::max(worstInside, error);
    } else {
      // Outside: the velocity of water within the distance to the surface plus the
      // widest kernel's reach (4 spacings: anisotropic kernels stretch 2x along a flat
      // surface), carried out along the grid's axes.
      const double allowed =
          omega.norm() * (double(phi.getValue(voxel.getCoord())) + kKernelReach) / double(exactAt(x).norm());
      worstOutside = std::max(worstOutside, error / allowed);
    }
  }
  // At the surface, as the mesh vertices get it (sampleVelocity: trilinear).
  double worstSurface = 0;
  for (int i = 0; i < 400; ++i) {  // rays from the block's centre
    const double z = 1 - 2 * (i + 0.5) / 400, r = std::sqrt(1 - z * z), turn = i * 2.399963229728653;
    const Vec3d centre = corner + Vec3d::Constant(6 * kSpacing);
    const Vec3d direction(r * std::cos(turn), r * std::sin(turn), z);
    const double t = test::zeroCrossing(*made.surface, centre, direction, 0.4);
    ASSERT_FALSE(std::isnan(t));
    const Vec3d p = centre + t * direction;
    const openvdb::Vec3d x(p.x(), p.y(), p.z());
    const Eigen::Vector3f sampled = sampleVelocity(*made.velocity, {p.cast<float>()})[0];
    worstSurface = std::max(worstSurface, errorAt(x, openvdb::Vec3s(sampled.x(), sampled.y(), sampled.z())) *
                                              exactAt(x).norm() /
                                              (omega.norm() * kSurfaceReach));
  }
  std::printf("rotating block (%s): worst relative error %.4f inside the band; at the surface %.2f and "
              "outside %.2f of their bound\n",
              surfaceMethodName(GetParam()).c_str(), worstInside, worstSurface, worstOutside);
  EXPECT_LT(worstInside, 0.03);
  EXPECT_LT(worstSurface, 1.0);
  EXPECT_LT(worstOutside, 1.0);
}

INSTANTIATE_TEST_SUITE_P(Methods, VelocityGrid,
                         ::testing::Values(SurfaceMethod::AnisotropicKernels, SurfaceMethod::SmoothSpheres,
                                           SurfaceMethod::UnionOfSpheres),
                         [](const auto& info) { return surfaceMethodName(info.param); });

TEST(VelocityGrid, GoesIntoTheVdbAndThePlyAndTurnsWithTheAxes) {
  const auto points = test::latticeBall(Vec3d(0.2, 0.1, 0.4), 6 * kSpacing, kSpacing, 0.05 * kSpacing);
  const Vec3r u(0.5, 1.0, -2.0);
  const std::vector<Vec3r> velocities(points.size(), u);
  const fs::path dir = fs::path(CASCADE_BINARY_DIR) / "test_scratch" / "velocity_grid";
  fs::remove_all(dir);
  fs::create_directories(dir);
  for (bool yUp : {false, true}) {
    SurfaceOptions options;
    options.vdbYUp = yUp;
    options.meshYUp = yUp;
    const std::string name = yUp ? "yup" : "zup";
    const SurfaceResult result =
        surfaceParticles(points, velocities, kSpacing, options, dir / (name + ".vdb"), dir / (name + ".ply"));
    ASSERT_TRUE(result.hasVelocity);
    ASSERT_EQ(result.mesh.velocities.size(), result.mesh.vertices.size());
    // In the file's axes: y-up stores (x, y, z) as (x, z, -y), vectors too.
    const Eigen::Vector3f expected = yUp ? Eigen::Vector3f(float(u.x()), float(u.z()), float(-u.y())) : u.cast<float>();

    const TriangleMesh back = readPly(dir / (name + ".ply"));
    ASSERT_EQ(back.vertices.size(), result.mesh.vertices.size());
    ASSERT_EQ(back.velocities.size(), back.vertices.size());
    for (const Eigen::Vector3f& v : back.velocities) ASSERT_LT((v - expected).norm(), 1e-3f * expected.norm());

    openvdb::io::File file((dir / (name + ".vdb")).string());
    file.open();
    auto v = openvdb::gridPtrCast<openvdb::Vec3SGrid>(file.readGrid("v"));
    auto surface = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("surface"));
    file.close();
    ASSERT_TRUE(v && surface);
    EXPECT_EQ(v->activeVoxelCount(), surface->activeVoxelCount());
    for (auto value = v->cbeginValueOn(); value; ++value)
      ASSERT_LT((Eigen::Vector3f(value->x(), value->y(), value->z()) - expected).norm(), 1e-3f * expected.norm());
    // The two grids share their lattice, so the velocity at a surface point is found
    // through the same transform.
    EXPECT_EQ(v->transform(), surface->transform());
  }
}

TEST(VelocityGrid, CanBeLeftOut) {
  const auto points = test::latticeBall(Vec3d(0, 0, 0), 5 * kSpacing, kSpacing);
  const std::vector<Vec3r> velocities(points.size(), Vec3r(1, 0, 0));
  SurfaceOptions options;
  options.velocity = false;
  const SurfaceResult result = surfaceParticles(points, velocities, kSpacing, options);
  EXPECT_FALSE(result.hasVelocity);
  EXPECT_TRUE(result.mesh.velocities.empty());
  EXPECT_FALSE(surfaceParticles(points, kSpacing, SurfaceOptions{}).hasVelocity);  // no velocities given
}


// sampleVelocity reads most cells straight from their leaf; the plain trilinear sum over
// the active corners, renormalised, read voxel by voxel through the tree, must agree:
// cells inside a leaf and across its faces, inactive corners, an active tile, no
// voxel at all, and a lattice with an offset (the general transform).
TEST(VelocityGrid, VertexSamplesAreTheTrilinearMeanOfTheActiveCorners) {
  openvdb::initialize();
  std::mt19937 random(7);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  for (const bool offset : {false, true}) {
    auto grid = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.0f));
    auto transform = openvdb::math::Transform::createLinearTransform(0.01);
    if (offset) transform->postTranslate(openvdb::Vec3d(0.0023, -0.0041, 0.0017));
    grid->setTransform(transform);
    auto access = grid->getAccessor();
    const openvdb::CoordBBox filled(openvdb::Coord(-9, -3, 0), openvdb::Coord(14, 12, 21));
    for (auto c = filled.begin(); c; ++c) {
      const openvdb::Vec3s value(unit(random), unit(random), unit(random));
      if (unit(random) > -0.8f) access.setValueOn(*c, value);  // a tenth stay inactive
      else access.setValueOff(*c, value);                       // (with a value that must not count)
    }
    grid->tree().addTile(1, openvdb::Coord(32, 0, 0), openvdb::Vec3s(0.5f, -0.25f, 2.0f), true);  // 8^3 tile
    std::vector<Eigen::Vector3f> points;
    for (int i = 0; i < 20000; ++i) {
      const openvdb::Vec3d index(-11 + 55 * (0.5 + 0.5 * unit(random)), -5 + 20 * (0.5 + 0.5 * unit(random)),
                                 -2 + 26 * (0.5 + 0.5 * unit(random)));
      const openvdb::Vec3d world = grid->indexToWorld(index);
      points.emplace_back(float(world.x()), float(world.y()), float(world.z()));
    }
    const std::vector<Eigen::Vector3f> sampled = sampleVelocity(*grid, points);
    ASSERT_EQ(sampled.size(), points.size());
    std::size_t fast = 0, partial = 0, empty = 0;
    const auto& tree = grid->constTree();
    for (std::size_t i = 0; i < points.size(); ++i) {
      const openvdb::Vec3d index = grid->worldToIndex(openvdb::Vec3d(points[i].x(), points[i].y(), points[i].z()));
      const openvdb::Coord cell = openvdb::Coord::floor(index);
      const openvdb::Vec3d f = index - cell.asVec3d();
      openvdb::Vec3d sum(0.0);
      double weightSum = 0;
      int active = 0;
      for (int corner = 0; corner < 8; ++corner) {
        const int dx = corner >> 2, dy = (corner >> 1) & 1, dz = corner & 1;
        openvdb::Vec3s value;
        if (!tree.probeValue(cell.offsetBy(dx, dy, dz), value)) continue;
        const double w = (dx ? f.x() : 1 - f.x()) * (dy ? f.y() : 1 - f.y()) * (dz ? f.z() : 1 - f.z());
        sum += w * openvdb::Vec3d(value);
        weightSum += w;
        ++active;
      }
      const openvdb::Vec3d expected = weightSum > 0 ? sum / weightSum : openvdb::Vec3d(0.0);
      fast += active == 8 && (cell.x() & 7) < 7 && (cell.y() & 7) < 7 && (cell.z() & 7) < 7;
      partial += active > 0 && active < 8;
      empty += active == 0;
      // Corners with a tiny weight can carry the renormalisation far: the bound scales with it.
      const double bound = 2e-5 * (1 + 1 / std::max(weightSum, 1e-3));
      ASSERT_NEAR(sampled[i].x(), expected.x(), bound) << i << " at cell " << cell;
      ASSERT_NEAR(sampled[i].y(), expected.y(), bound) << i << " at cell " << cell;
      ASSERT_NEAR(sampled[i].z(), expected.z(), bound) << i << " at cell " << cell;
    }
    // Every kind of cell was met.
    EXPECT_GT(fast, 1000u);
    EXPECT_GT(partial, 2000u);
    EXPECT_GT(empty, 500u);
  }
}

// The band's unknown voxels: Jacobi sweeps of the mean of the known face neighbours,
// here read voxel by voxel through the tree, give the same values bit for bit (the same
// sums in the same order) and the same active set as velocityOverBand's leaf-wise sweeps.
TEST(VelocityGrid, TheBandIsFilledByJacobiSweepsOfTheKnownFaceNeighbours) {
  openvdb::initialize();
  auto band = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(0.3f, openvdb::Vec3f(0.01f, -0.02f, 0.0f), 0.02f,
                                                                       3.0f);
  // Known: voxels of a thick slab through the sphere's inside, and some well outside
  // the band (which must not stay on), with random values.
  std::mt19937 random(11);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  auto known = std::make_shared<openvdb::Vec3STree>(openvdb::Vec3s(0.0f));
  const openvdb::CoordBBox slab(openvdb::Coord(-40, -40, -3), openvdb::Coord(40, 40, 4));
  for (auto c = slab.begin(); c; ++c)
    if (band->tree().getValue(*c) < 0 && unit(random) > -0.6f)
      known->setValueOn(*c, openvdb::Vec3s(unit(random), unit(random), unit(random)));
  known->setValueOn(openvdb::Coord(60, 60, 60), openvdb::Vec3s(9.0f));
  const int sweeps = 5;
  // The reference, on a plain copy whose known voxels off the band are dropped (deep
  // inside the sphere and far outside: neither is a known neighbour).
  openvdb::Vec3STree reference(*known);
  for (auto voxel = known->cbeginValueOn(); voxel; ++voxel)
    if (!band->tree().isValueOn(voxel.getCoord())) reference.setValueOff(voxel.getCoord(), openvdb::Vec3s(0.0f));
  std::set<openvdb::Coord> unknown;
  for (auto voxel = band->tree().cbeginValueOn(); voxel; ++voxel)
    if (!reference.isValueOn(voxel.getCoord())) unknown.insert(voxel.getCoord());
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    std::vector<std::pair<openvdb::Coord, openvdb::Vec3s>> resolved;
    for (const openvdb::Coord& c : unknown) {
      openvdb::Vec3s sum(0.0f);
      int count = 0;
      for (int axis = 0; axis < 3; ++axis)
        for (int side = -1; side <= 1; side += 2) {
          openvdb::Coord neighbor = c;
          neighbor[axis] += side;
          openvdb::Vec3s value;
          if (reference.probeValue(neighbor, value)) sum += value, ++count;
        }
      if (count > 0) resolved.emplace_back(c, sum / float(count));
    }
    for (const auto& [c, value] : resolved) {
      reference.setValueOn(c, value);
      unknown.erase(c);
    }
  }
  ASSERT_FALSE(unknown.empty());  // some voxels are left for the mean: not compared here
  const openvdb::Vec3STree given(*known);
  const openvdb::Vec3SGrid::Ptr v = detail::velocityOverBand(*band, known, sweeps);  // consumes `known`
  EXPECT_EQ(v->activeVoxelCount(), band->activeVoxelCount());
  std::size_t compared = 0, filled = 0;
  for (auto voxel = band->tree().cbeginValueOn(); voxel; ++voxel) {
    const openvdb::Coord c = voxel.getCoord();
    if (unknown.count(c)) continue;
    openvdb::Vec3s expected;
    ASSERT_TRUE(reference.probeValue(c, expected));
    ASSERT_EQ(v->tree().getValue(c), expected) << c;
    ++compared;
    filled += !given.isValueOn(c);
  }
  EXPECT_GT(filled, 5000u);
  EXPECT_GT(compared, filled);
  EXPECT_FALSE(v->tree().isValueOn(openvdb::Coord(60, 60, 60)));
}

} // namespace
