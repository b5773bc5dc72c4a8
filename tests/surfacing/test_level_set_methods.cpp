// Level sets of known particle arrangements: a ball keeps its radius, a flat
// block keeps a flat top (surfacing/LevelSetMethods.h).
#include "SurfacingTestUtil.h"

#include "surfacing/LevelSetFiltering.h"
#include "surfacing/LevelSetMethods.h"

#include <gtest/gtest.h>

#include <algorithm>

using namespace cascade;
using namespace cascade::surfacing;

namespace {

constexpr double kSpacing = 0.02;

openvdb::FloatGrid::Ptr levelSet(SurfaceMethod method, const std::vector<Vec3r>& points,
                                 SurfaceFilter filter = SurfaceFilter::None, int passes = 0) {
  openvdb::initialize();
  LevelSetSettings settings;
  settings.spacing = kSpacing;
  settings.voxelSize = 0.5 * kSpacing;
  openvdb::FloatGrid::Ptr grid = particlesToLevelSet(method, points, settings).surface;
  if (passes >= 0) filterLevelSet(*grid, filter, passes);
  return grid;
}

/// Zero crossings along 200 directions (a Fibonacci sphere) from the centre.
std::vector<double> ballRadii(const openvdb::FloatGrid& grid, const Vec3d& center, double maxRadius) {
  std::vector<double> radii;
  const int n = 200;
  for (int i = 0; i < n; ++i) {
    const double z = 1 - 2 * (i + 0.5) / n, r = std::sqrt(1 - z * z), phi = i * 2.399963229728653;
    radii.push_back(test::zeroCrossing(grid, center, Vec3d(r * std::cos(phi), r * std::sin(phi), z), maxRadius));
  }
  return radii;
}

struct MethodCase {
  SurfaceMethod method;
  double radiusTolerance;  // in voxels
};

void PrintTo(const MethodCase& c, std::ostream* os) { *os << surfaceMethodName(c.method); }

class BallTest : public ::testing::TestWithParam<MethodCase> {};

TEST_P(BallTest, ZeroCrossingAtVolumeRadius) {
  const Vec3d center(0.013, -0.021, 0.5);  // off the voxel lattice
  const auto points = test::latticeBall(center, 10 * kSpacing, kSpacing);
  // The radius of a ball with the particles' volume.
  const double expected = std::cbrt(3.0 * points.size() * std::pow(kSpacing, 3) / (4 * M_PI));
  const auto grid = levelSet(GetParam().method, points, SurfaceFilter::MeanCurvature, 1);
  const auto radii = ballRadii(*grid, center, 2 * expected);
  double mean = 0, worst = 0;
  for (double r : radii) {
    ASSERT_FALSE(std::isnan(r));
    mean += r / radii.size();
    worst = std::max(worst, std::abs(r - expected));
  }
  const double voxel = 0.5 * kSpacing;
  std::printf("%s: expected %.5f mean %.5f (%.3f voxels) worst %.3f voxels\n",
              surfaceMethodName(GetParam().method).c_str(), expected, mean, (mean - expected) / voxel,
              worst / voxel);
  EXPECT_LT(std::abs(mean - expected), GetParam().radiusTolerance * voxel);
  EXPECT_LT(worst, GetParam().radiusTolerance * voxel + 0.25 * voxel);
}

INSTANTIATE_TEST_SUITE_P(Methods, BallTest,
                         ::testing::Values(MethodCase{SurfaceMethod::AnisotropicKernels, 0.5},
                                           MethodCase{SurfaceMethod::SmoothSpheres, 0.5},
                                           MethodCase{SurfaceMethod::UnionOfSpheres, 1.5}),
                         [](const auto& info) { return surfaceMethodName(info.param.method); });

/// Heights of the top surface of a block over its central part.
std::vector<double> topHeights(const openvdb::FloatGrid& grid, const Vec3d& corner, int nx, int ny, double top) {
  std::vector<double> heights;
  for (double u = 0.3; u <= 0.7001; u += 0.025)
    for (double v = 0.3; v <= 0.7001; v += 0.025) {
      const Vec3d start = corner + Vec3d(u * nx * kSpacing, v * ny * kSpacing, top - 3 * kSpacing - corner.z());
      heights.push_back(start.z() + test::zeroCrossing(grid, start, Vec3d(0, 0, 1), 6 * kSpacing));
    }
  return heights;
}

class FlatBlockTest : public ::testing::TestWithParam<MethodCase> {};

TEST_P(FlatBlockTest, TopIsFlatAndKeepsVolume) {
  const Vec3d corner(0.0031, 0.0047, 0.0013);
  const int nx = 30, ny = 30, nz = 10;
  const auto points = test::latticeBlock(corner, nx, ny, nz, kSpacing, 0.05 * kSpacing);
  const double top = corner.z() + nz * kSpacing;  // top of the particles' volume
  const auto grid = levelSet(GetParam().method, points, SurfaceFilter::MeanCurvature, 1);
  const auto heights = topHeights(*grid, corner, nx, ny, top);
  double lo = 1e9, hi = -1e9, mean = 0;
  for (double h : heights) {
    ASSERT_FALSE(std::isnan(h));
    lo = std::min(lo, h);
    hi = std::max(hi, h);
    mean += h / heights.size();
  }
  std::printf("%s: top %.5f mean %.5f (%.3f spacings) spread %.4f spacings\n",
              surfaceMethodName(GetParam().method).c_str(), top, mean, (mean - top) / kSpacing,
              (hi - lo) / kSpacing);
  if (GetParam().method == SurfaceMethod::AnisotropicKernels) {
    EXPECT_LT(hi - lo, 0.1 * kSpacing);
  }
  EXPECT_LT(std::abs(mean - top), GetParam().radiusTolerance * 0.5 * kSpacing);
}

INSTANTIATE_TEST_SUITE_P(Methods, FlatBlockTest,
                         ::testing::Values(MethodCase{SurfaceMethod::AnisotropicKernels, 0.5},
                                           MethodCase{SurfaceMethod::SmoothSpheres, 0.5},
                                           MethodCase{SurfaceMethod::UnionOfSpheres, 1.5}),
                         [](const auto& info) { return surfaceMethodName(info.param.method); });

} // namespace

namespace {

/// The leaf-parallel mean-curvature filter (and its renormalisation) against
/// OpenVDB's LevelSetFilter with the same scheme: the same zero crossings within
/// a small fraction of a voxel, the same band half width, deterministic.
TEST(LevelSetFilter, MeanCurvatureMatchesOpenVdb) {
  const Vec3d center(0.013, -0.021, 0.5);
  const auto points = test::latticeBall(center, 10 * kSpacing, kSpacing);
  const double expected = std::cbrt(3.0 * points.size() * std::pow(kSpacing, 3) / (4 * M_PI));
  const double voxel = 0.5 * kSpacing;
  for (int passes : {0, 1, 3}) {
    const auto raw = levelSet(SurfaceMethod::SmoothSpheres, points, SurfaceFilter::None, -1);
    auto ours = raw->deepCopy(), theirs = raw->deepCopy(), again = raw->deepCopy();
    filterLevelSet(*ours, SurfaceFilter::MeanCurvature, passes);
    filterLevelSet(*again, SurfaceFilter::MeanCurvature, passes);
    filterLevelSetOpenVdb(*theirs, SurfaceFilter::MeanCurvature, passes);
    const auto a = ballRadii(*ours, center, 2 * expected), b = ballRadii(*theirs, center, 2 * expected);
    double worst = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      ASSERT_FALSE(std::isnan(a[i]));
      worst = std::max(worst, std::abs(a[i] - b[i]));
    }
    std::printf("%d passes: largest zero-crossing difference %.4f voxels; active voxels %zu vs %zu\n", passes,
                worst / voxel, std::size_t(ours->activeVoxelCount()), std::size_t(theirs->activeVoxelCount()));
    EXPECT_LT(worst, 0.02 * voxel);
    EXPECT_NEAR(double(ours->activeVoxelCount()), double(theirs->activeVoxelCount()),
                0.1 * double(theirs->activeVoxelCount()));
    // Every active value is inside the band, every inactive one is +-background.
    for (auto it = ours->tree().cbeginValueAll(); it; ++it) {
      if (it.isValueOn()) ASSERT_LT(std::abs(*it), ours->background());
      else ASSERT_EQ(std::abs(*it), ours->background());
    }
    // Bit-identical on a second run (no dependence on thread timing).
    std::size_t differing = 0;
    for (auto it = ours->tree().cbeginValueOn(); it; ++it)
      if (again->tree().getValue(it.getCoord()) != *it) ++differing;
    EXPECT_EQ(differing, 0u);
    EXPECT_EQ(ours->activeVoxelCount(), again->activeVoxelCount());
  }
}

} // namespace
