// Unit tests of deforming mesh sequences: loading and its errors, the
// surface and its velocity between frames, type I samples made once per frame
// interval and placed by interpolation, and the guard against a wall that moves
// onto a particle.
#include "DeformingTestSequences.h"
#include "TestTempDir.h"

#include "libsph/Errors.h"
#include "libsph/boundary/BoundaryParticles.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>

namespace cascade::test {

namespace {

constexpr double kFps = 10;

/// A 0.1 m cube that moves +x by 0.02 m and grows 0.01 m per frame (frames 1-4).
void growingCube(int k, Vec3r& lo, Vec3r& hi) {
  const Real x = Real(0.02) * Real(k - 1), grow = Real(0.01) * Real(k - 1);
  lo = Vec3r(Real(0.3) + x, Real(0.3), Real(0.3));
  hi = lo + Vec3r::Constant(Real(0.1) + grow);
}

std::filesystem::path scratch(const std::string& name) {
  static const std::filesystem::path base = freshTempDir("deforming_mesh");
  const std::filesystem::path dir = base / name;
  std::filesystem::create_directories(dir);
  return dir;
}

std::unique_ptr<DeformingMeshBoundary> loadCube(const std::string& pattern, int lastFrame = 4) {
  auto solid = std::make_unique<DeformingMeshBoundary>(loadMeshSequence(pattern, lastFrame, kFps, Transform(), "test"));
  solid->setName("flex");
  return solid;
}

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

} // namespace

TEST(DeformingMesh, FramePatternsNameTheFiles) {
  EXPECT_EQ(sequenceFramePath("a/paddle.####.obj", 7), "a/paddle.0007.obj");
  EXPECT_EQ(sequenceFramePath("a/paddle.##.obj", 123), "a/paddle.123.obj");
  EXPECT_EQ(sequenceFramePath("a/p#.obj", 0), "a/p0.obj");
}

TEST(DeformingMesh, SurfaceAndVelocityAreInterpolatedBetweenFrames) {
  const std::string pattern = writeBoxSequence(scratch("interpolate"), "cube", 1, 4, growingCube);
  auto solid = loadCube(pattern);
  EXPECT_EQ(solid->sequence().firstFrame, 1);
  EXPECT_EQ(solid->sequence().lastFrame(), 4);
  // The fastest point: the far corner, (0.02 + 0.01, 0.01, 0.01) m per frame.
  EXPECT_NEAR(solid->maxMotionSpeed(), std::sqrt(0.03 * 0.03 + 2 * 0.01 * 0.01) * kFps, 1e-5);
  Vec3r lo, hi;
  // Before frame 1's time the first frame holds, still.
  solid->resetTo(0.05);
  solid->bounds(lo, hi);
  EXPECT_NEAR(double(lo.x()), 0.3, 1e-6);
  EXPECT_NEAR(double(hi.x()), 0.4, 1e-6);
  EXPECT_EQ(solid->maxSurfaceSpeed(), 0.0);
  EXPECT_EQ(solid->velocityAt(Vec3r(0.35f, 0.35f, 0.4f)), Vec3r::Zero());
  // A quarter of the way from frame 2 (t = 0.2 s) to frame 3.
  solid->moveTo(0.225);
  solid->bounds(lo, hi);
  EXPECT_NEAR(double(lo.x()), 0.3 + 0.02 * 1.25, 1e-6);
  EXPECT_NEAR(double(hi.x()), 0.3 + 0.02 * 1.25 + 0.1 + 0.01 * 1.25, 1e-6);
  EXPECT_NEAR(double(hi.z()), 0.4 + 0.0125, 1e-6);
  const Boundary::Deformation d = solid->deformation();
  EXPECT_EQ(d.interval, 2);
  EXPECT_NEAR(double(d.weight), 0.25, 1e-6);
  EXPECT_NEAR(double(d.rate), kFps, 1e-6);
  // A point on the top face: lo moves at 0.2 m/s in x, the far corner at 0.3, z at 0.1.
  const Vec3r top(lo.x() + 0.5f * (hi.x() - lo.x()), lo.y() + 0.5f * (hi.y() - lo.y()), hi.z());
  const Vec3r v = solid->velocityAt(top);
  EXPECT_NEAR(double(v.x()), 0.25, 1e-4);
  EXPECT_NEAR(double(v.y()), 0.05, 1e-4);
  EXPECT_NEAR(double(v.z()), 0.1, 1e-4);
  // Mirror maps carry it: the map of a particle above the top face.
  std::vector<MirrorMap> maps;
  solid->mirrorMaps(top + Vec3r(0, 0, 0.005f), 0.02f, 3, maps);
  ASSERT_EQ(maps.size(), 1u);
  EXPECT_NEAR(double((maps[0].wallVelocity - v).norm()), 0.0, 1e-4);
  EXPECT_NEAR(double(maps[0].apply(top + Vec3r(0, 0, 0.005f)).z()), double(hi.z()) - 0.005, 1e-5);
  // After the last frame's time it holds.
  solid->moveTo(1.0);
  solid->bounds(lo, hi);
  EXPECT_NEAR(double(lo.x()), 0.36, 1e-6);
  EXPECT_NEAR(double(hi.x()), 0.36 + 0.13, 1e-6);
  EXPECT_EQ(solid->maxSurfaceSpeed(), 0.0);
  EXPECT_TRUE(solid->isInside(Vec3r(0.45f, 0.35f, 0.35f)));
  EXPECT_FALSE(solid->isInside(Vec3r(0.33f, 0.35f, 0.35f)));
}

TEST(DeformingMesh, AnOptionalFrameZeroStandsAtTimeZero) {
  const std::string pattern = writeBoxSequence(scratch("zero"), "cube", 0, 2, [](int k, Vec3r& lo, Vec3r& hi) {
    lo = Vec3r(Real(0.1) * Real(k), 0, 0);
    hi = lo + Vec3r::Constant(0.1f);
  });
  auto solid = loadCube(pattern, 2);
  EXPECT_EQ(solid->sequence().firstFrame, 0);
  solid->resetTo(0.05);  // half way from frame 0 to frame 1
  Vec3r lo, hi;
  solid->bounds(lo, hi);
  EXPECT_NEAR(double(lo.x()), 0.05, 1e-6);
  EXPECT_NEAR(solid->maxSurfaceSpeed(), 1.0, 1e-5);
}

TEST(DeformingMesh, BadSequencesAreRefusedNamingTheFile) {
  const std::filesystem::path dir = scratch("bad");
  // A missing frame.
  std::string pattern = writeBoxSequence(dir, "gap", 1, 2, growingCube);
  EXPECT_EQ(errorOf([&] { loadCube(pattern, 3); }),
            sequenceFramePath(pattern, 3) + ": test: frame 3 of the mesh sequence is missing (the bake runs to frame 3)");
  // Frames that do not share their triangles.
  pattern = writeBoxSequence(dir, "topology", 1, 3, growingCube);
  {
    TriangleMesh mesh = boxMesh(Vec3r(0, 0, 0), Vec3r(1, 1, 1));
    std::swap(mesh.triangles[0], mesh.triangles[1]);
    writeObj(sequenceFramePath(pattern, 2), mesh);
  }
  EXPECT_NE(errorOf([&] { loadCube(pattern, 3); }).find(sequenceFramePath(pattern, 2) + ": test: frame 2 has 8 vertices"),
            std::string::npos);
  // An open mesh.
  pattern = writeBoxSequence(dir, "open", 1, 2, growingCube);
  {
    TriangleMesh mesh = boxMesh(Vec3r(0, 0, 0), Vec3r(1, 1, 1));
    mesh.triangles.pop_back();
    writeObj(sequenceFramePath(pattern, 1), mesh);
    writeObj(sequenceFramePath(pattern, 2), mesh);
  }
  EXPECT_EQ(errorOf([&] { loadCube(pattern, 2); }),
            sequenceFramePath(pattern, 1) +
                ": test: the mesh is not closed (3 open edges): a deforming obstacle must bound a volume in every frame");
  // A frame turned inside out (the box mirrored through its centre plane).
  pattern = writeBoxSequence(dir, "flip", 1, 2, [](int k, Vec3r& lo, Vec3r& hi) {
    lo = Vec3r::Zero();
    hi = Vec3r::Constant(0.1f);
    if (k == 2) std::swap(lo.x(), hi.x());
  });
  EXPECT_EQ(errorOf([&] { loadCube(pattern, 2); }),
            sequenceFramePath(pattern, 2) + ": test: the mesh bounds no volume or is turned inside out in this frame");
  // Unreadable OBJ.
  pattern = writeBoxSequence(dir, "broken", 1, 2, growingCube);
  std::ofstream(sequenceFramePath(pattern, 2)) << "v 0 0 0\nf 1 2 x\n";
  EXPECT_NE(errorOf([&] { loadCube(pattern, 2); }).find(sequenceFramePath(pattern, 2)), std::string::npos);
}

TEST(DeformingMesh, SamplesAreMadePerFrameIntervalAndPlacedBetween) {
  const std::string pattern = writeBoxSequence(scratch("samples"), "cube", 1, 4, growingCube);
  std::vector<BoundaryPtr> boundaries;
  boundaries.push_back(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(1, 1, 1)));
  boundaries.push_back(loadCube(pattern));
  auto& solid = static_cast<DeformingMeshBoundary&>(*boundaries[1]);
  const Real gap = 0.005f, radius = 0.01f;
  solid.resetTo(0.2);  // frame 2's time: the interval from frame 2 to 3
  BoundaryParticles particles;
  particles.sample(boundaries, gap, radius);
  const auto ownSamples = [&] {
    std::vector<std::pair<Vec3r, Vec3r>> own;
    for (std::size_t k = 0; k < particles.sampleCount(); ++k)
      if (particles.sampleOwners()[k] == 1)
        own.emplace_back(particles.samplePositions()[k], particles.sampleVelocity(std::uint32_t(k)));
    return own;
  };
  // At the interval's start: exactly the samples of frame 2's mesh (as a set).
  const std::vector<Vec3r> frame2 = sampleTriangles(boxMesh(Vec3r(0.32f, 0.3f, 0.3f), Vec3r(0.43f, 0.41f, 0.41f)), gap);
  std::vector<std::pair<Vec3r, Vec3r>> own = ownSamples();
  ASSERT_EQ(own.size(), frame2.size());
  {
    std::vector<Vec3r> both = frame2;
    for (const auto& [x, v] : own) both.push_back(x);
    removeDuplicateSamples(both, Real(1e-6));
    EXPECT_EQ(both.size(), frame2.size());
  }
  // Within the interval: the same surface points, each on the interpolated surface and
  // moving with it; the lists are the samples within the radius.
  Particles fluid;
  for (const Vec3r& p : {Vec3r(0.33f, 0.35f, 0.35f), Vec3r(0.38f, 0.36f, 0.418f), Vec3r(0.445f, 0.42f, 0.3f),
                         Vec3r(0.8f, 0.8f, 0.8f)})
    fluid.add(p, Vec3r::Zero(), ParticleId(fluid.size()));
  for (const double t : {0.2125, 0.25, 0.2875}) {
    solid.moveTo(t);
    particles.update(fluid, boundaries, radius, 0.02f, true, false);
    own = ownSamples();
    ASSERT_EQ(own.size(), frame2.size()) << "t = " << t;
    Vec3r lo, hi;
    solid.bounds(lo, hi);
    for (const auto& [x, v] : own) {
      // On a face of the box [lo, hi].
      const Real off = std::min({std::abs(x.x() - lo.x()), std::abs(x.x() - hi.x()), std::abs(x.y() - lo.y()),
                                 std::abs(x.y() - hi.y()), std::abs(x.z() - lo.z()), std::abs(x.z() - hi.z())});
      ASSERT_LT(double(off), 1e-6) << "t = " << t;
      ASSERT_NEAR(double((v - solid.velocityAt(x)).norm()), 0.0, 1e-4) << "t = " << t;
    }
    for (std::size_t i = 0; i < fluid.size(); ++i) {
      std::vector<std::uint32_t> listed(particles.sampleNeighbors().begin(i), particles.sampleNeighbors().end(i));
      std::sort(listed.begin(), listed.end());
      std::vector<std::uint32_t> brute;
      for (std::uint32_t k = 0; k < particles.sampleCount(); ++k)
        if (squaredDistance(particles.samplePositions()[k], fluid.position[i]) <= radius * radius) brute.push_back(k);
      EXPECT_EQ(listed, brute) << "particle " << i << ", t = " << t;
    }
    EXPECT_GT(particles.sampleNeighbors().count(1), 0u);
    EXPECT_EQ(particles.sampleNeighbors().count(3), 0u);
  }
  // The next interval re-samples on frame 3's (larger) mesh.
  solid.moveTo(0.31);
  particles.update(fluid, boundaries, radius, 0.02f, true, false);
  const std::vector<Vec3r> frame3 = sampleTriangles(boxMesh(Vec3r(0.34f, 0.3f, 0.3f), Vec3r(0.46f, 0.42f, 0.42f)), gap);
  EXPECT_EQ(ownSamples().size(), frame3.size());
  EXPECT_GT(frame3.size(), frame2.size());
}

TEST(DeformingMesh, AWallThatMovesOntoAParticleCountsAsPenetration) {
  // The cube's right face moves +x by 0.03 m per frame: a particle at rest 5 mm ahead of
  // it is overrun within half a frame.
  const std::string pattern = writeBoxSequence(scratch("guard"), "cube", 1, 4, growingCube);
  auto solid = loadCube(pattern);
  solid->resetTo(0.2);                           // the face at x = 0.43
  const Vec3r particle(0.4350f, 0.35f, 0.35f);
  ASSERT_FALSE(solid->isInside(particle));
  solid->moveTo(0.25);                           // ... at x = 0.445
  ASSERT_TRUE(solid->isInside(particle));
  Vec3r exit, normal;
  ASSERT_TRUE(solid->penetrated(particle, particle, 0.001f, exit, normal));
  EXPECT_NEAR(double(normal.x()), 1.0, 1e-6);
  EXPECT_NEAR(double(exit.x()), 0.445 + 0.001, 1e-5);
  EXPECT_FALSE(solid->isInside(exit));
  // A particle the face does not reach is left alone.
  const Vec3r clear(0.4500f, 0.35f, 0.35f);
  solid->resetTo(0.2);
  solid->moveTo(0.25);
  EXPECT_FALSE(solid->penetrated(clear, clear, 0.001f, exit, normal));
}

} // namespace cascade::test
