// surfaceFrames() over an OUT directory: good frames surface, bad caches (missing,
// truncated, foreign) are reported by name while the others still surface;
// complete outputs are skipped unless forced.
#include "SurfacingTestUtil.h"

#include "libsph/io/ParticleCache.h"
#include "libsph/io/TriangleMesh.h"
#include "surfacing/SurfaceStage.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

using namespace cascade;
namespace fs = std::filesystem;

namespace {

constexpr double kSpacing = 0.02;

ParticleFrame ballFrame(const Vec3d& center) {
  ParticleFrame frame;
  frame.position = test::latticeBall(center, 5 * kSpacing, kSpacing, 0.05 * kSpacing);
  frame.velocity.assign(frame.position.size(), Vec3r::Zero());
  for (std::size_t i = 0; i < frame.position.size(); ++i) frame.id.push_back(ParticleId(i));
  frame.density.assign(frame.position.size(), Real(1000));
  frame.pressure.assign(frame.position.size(), Real(0));
  frame.spacing = Real(kSpacing);
  return frame;
}

TEST(SurfaceStage, BadCachesAmongGoodOnes) {
  const fs::path root = fs::path(CASCADE_BINARY_DIR) / "test_scratch" / "surfacing_stage";
  fs::remove_all(root);
  const OutputLayout layout(root);
  fs::create_directories(layout.particlesDir());
  writeParticleFrame(layout.particles(1), ballFrame(Vec3d(0, 0, 0)));
  writeParticleFrame(layout.particles(2), ballFrame(Vec3d(0.01, 0, 0)));
  {  // frame 2 truncated to half its size
    const auto size = fs::file_size(layout.particles(2));
    fs::resize_file(layout.particles(2), size / 2);
  }
  writeParticlePly(layout.particlesPly(3), ballFrame(Vec3d(0.02, 0, 0)));  // another tool's points
  std::ofstream(layout.particles(4)) << "this is not an OpenVDB file\n";
  // frame 5 missing

  std::vector<int> progressFrames;
  SurfaceOptions options;
  const auto reports = surfaceFrames(layout, FrameRange{1, 5}, options,
                                     [&](const SurfaceFrameReport& r) { progressFrames.push_back(r.frame); });
  ASSERT_EQ(reports.size(), 5u);
  EXPECT_EQ(progressFrames.size(), 5u);
  for (int frame : {1, 3}) {
    const auto& report = reports[frame - 1];
    EXPECT_TRUE(report.error.empty()) << report.error;
    EXPECT_GT(report.triangles, 100u);
    EXPECT_TRUE(fs::exists(layout.surface(frame)));
    EXPECT_TRUE(fs::exists(layout.mesh(frame)));
    EXPECT_EQ(readObj(layout.mesh(frame)).triangles.size(), report.triangles);
  }
  for (int frame : {2, 4, 5}) {
    const auto& report = reports[frame - 1];
    EXPECT_TRUE(report.badInput) << frame << ": " << report.error;
    const std::string name = "particles." + OutputLayout::pad(frame);
    EXPECT_NE(report.error.find(name), std::string::npos) << report.error;
    EXPECT_EQ(report.error.find('\n'), std::string::npos);
    EXPECT_FALSE(fs::exists(layout.surface(frame)));
    EXPECT_FALSE(fs::exists(layout.mesh(frame)));
  }

  // A second run skips complete outputs; --force redoes them.
  const auto mtime = fs::last_write_time(layout.mesh(1));
  const auto again = surfaceFrames(layout, FrameRange{1, 1}, options);
  ASSERT_EQ(again.size(), 1u);
  EXPECT_TRUE(again[0].skipped);
  EXPECT_EQ(fs::last_write_time(layout.mesh(1)), mtime);
  options.force = true;
  const auto forced = surfaceFrames(layout, FrameRange{1, 1}, options);
  EXPECT_FALSE(forced[0].skipped);
  EXPECT_TRUE(forced[0].error.empty());

  // An open range takes the frames on disk.
  options.force = false;
  const auto open = surfaceFrames(layout, FrameRange{}, options);
  EXPECT_EQ(open.size(), 4u);  // 1, 2, 3, 4
}

TEST(SurfaceStage, SpacingEstimatedForPlainPoints) {
  const auto points = test::latticeBall(Vec3d(0, 0, 0), 5 * kSpacing, kSpacing, 0.02 * kSpacing);
  const SurfaceResult result = surfaceParticles(points, 0, SurfaceOptions{});
  EXPECT_NEAR(result.particleSpacing, kSpacing, 0.03 * kSpacing);
  EXPECT_NEAR(result.voxelSize, 0.5 * result.particleSpacing, 1e-12);
}

} // namespace
