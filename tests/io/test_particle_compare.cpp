// Two particle caches side by side (ParticleCompare.h, `cascade inspect A --against B`):
// exact differences for frames that differ by known moves, order, extra and
// missing particles; exit 2 when a file cannot be read; two meshes' Hausdorff distance.
#include "bake/CascadeProcess.h"
#include "TestTempDir.h"
#include "libsph/Errors.h"
#include "libsph/io/ParticleCompare.h"
#include "libsph/io/TriangleMesh.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace cascade;
namespace fs = std::filesystem;

namespace {
ParticleFrame lattice(int n) {
  ParticleFrame frame;
  for (int i = 0; i < n; ++i) {
    frame.position.emplace_back(Real(0.01 * i), Real(0.02), Real(0.5));
    frame.velocity.emplace_back(Real(0.1 * i), 0, 0);
    frame.id.push_back(ParticleId(100 + i));
  }
  frame.spacing = Real(0.01);
  return frame;
}
} // namespace

TEST(ParticleCompare, MatchesByIdWhateverTheOrder) {
  const ParticleFrame a = lattice(50);
  ParticleFrame b = a;
  std::reverse(b.position.begin(), b.position.end());
  std::reverse(b.velocity.begin(), b.velocity.end());
  std::reverse(b.id.begin(), b.id.end());
  const ParticleDifference same = compareParticleFrames(a, b);
  EXPECT_TRUE(same.byId);
  EXPECT_EQ(same.matched, 50u);
  EXPECT_EQ(same.maxPosition, 0.0);
  EXPECT_EQ(same.maxVelocity, 0.0);
  // One particle moved by (3, 4, 0) mm and sped up by 2 m/s; one more only in b.
  b.position[10] += Vec3r(Real(0.003), Real(0.004), 0);
  b.velocity[10] += Vec3r(0, 0, 2);
  b.position.emplace_back(1, 1, 1);
  b.velocity.emplace_back(0, 0, 0);
  b.id.push_back(7);
  const ParticleDifference d = compareParticleFrames(a, b);
  EXPECT_EQ(d.matched, 50u);
  EXPECT_EQ(d.onlyInA, 0u);
  EXPECT_EQ(d.onlyInB, 1u);
  EXPECT_NEAR(d.maxPosition, 0.005, 1e-7);
  EXPECT_EQ(d.maxPositionId, b.id[10]);
  EXPECT_NEAR(d.rmsPosition, 0.005 / std::sqrt(50.0), 1e-8);
  EXPECT_NEAR(d.maxVelocity, 2.0, 1e-6);
}

TEST(ParticleCompare, FramesWithoutIdsMatchByOrderAndMixedOnesAreRefused) {
  ParticleFrame a = lattice(20), b = lattice(18);
  a.id.clear();
  b.id.clear();
  b.position[3].z() += Real(0.25);
  const ParticleDifference d = compareParticleFrames(a, b);
  EXPECT_FALSE(d.byId);
  EXPECT_EQ(d.matched, 18u);
  EXPECT_EQ(d.onlyInA, 2u);
  EXPECT_NEAR(d.maxPosition, 0.25, 1e-6);
  EXPECT_EQ(d.maxPositionId, 3u);
  EXPECT_THROW(compareParticleFrames(a, lattice(20)), InputError);
}

TEST(ParticleCompare, InspectAgainstPrintsTheDifferencesAndExits2OnAnUnreadableFile) {
  const fs::path dir = test::freshTempDir("compare");
  const ParticleFrame a = lattice(30);
  ParticleFrame b = a;
  b.position[29].x() += Real(0.125);
  writeParticleFrame(dir / "a.vdb", a);
  writeParticleFrame(dir / "b.vdb", b);
  const fs::path log = dir / "inspect.log";
  ASSERT_EQ(test::run({"inspect", (dir / "a.vdb").string(), "--against", (dir / "b.vdb").string()}, log), 0)
      << test::readLog(log);
  const std::string text = test::readLog(log);
  EXPECT_NE(text.find("count: 30 30\n"), std::string::npos) << text;
  EXPECT_NE(text.find("matched: 30 (by id)\n"), std::string::npos) << text;
  const std::size_t at = text.find("max_position_difference_m: ");
  ASSERT_NE(at, std::string::npos) << text;
  EXPECT_NEAR(std::stod(text.substr(at + 27)), 0.125, 1e-5) << text;  // positions are stored in fixed point
  EXPECT_NE(text.find("(id 129)"), std::string::npos) << text;
  writeTextAtomically(dir / "broken.vdb", "not a vdb");
  const fs::path bad = dir / "bad.log";
  EXPECT_EQ(test::run({"inspect", (dir / "a.vdb").string(), "--against", (dir / "broken.vdb").string()}, bad), 2);
  const std::string line = test::readLog(bad);
  EXPECT_EQ(line.find('\n'), line.size() - 1) << line;
  EXPECT_NE(line.find("broken.vdb"), std::string::npos) << line;
}

namespace {
/// The unit cube [0, 1]^3 raised by `dz`, two triangles a face, outward.
TriangleMesh cube(float dz) {
  TriangleMesh mesh;
  for (int k = 0; k < 8; ++k) mesh.vertices.emplace_back(float(k & 1), float((k >> 1) & 1), float((k >> 2) & 1) + dz);
  const std::uint32_t faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : faces) {
    mesh.triangles.push_back({f[0], f[1], f[2]});
    mesh.triangles.push_back({f[0], f[2], f[3]});
  }
  return mesh;
}
} // namespace

// Two meshes (an OBJ and a PLY): the symmetric Hausdorff distance. A unit cube against
// itself raised by 0.25: its bottom corners are 0.25 from the raised cube, nothing further.
TEST(ParticleCompare, InspectAgainstTwoMeshesPrintsTheirHausdorffDistance) {
  const fs::path dir = test::freshTempDir("compare_meshes");
  writeObj(dir / "a.obj", cube(0));
  writePly(dir / "b.ply", cube(0.25f));
  const fs::path log = dir / "inspect.log";
  ASSERT_EQ(test::run({"inspect", (dir / "a.obj").string(), "--against", (dir / "b.ply").string()}, log), 0)
      << test::readLog(log);
  const std::string text = test::readLog(log);
  EXPECT_NE(text.find("triangles: 12 12\n"), std::string::npos) << text;
  const std::size_t at = text.find("hausdorff_distance_m: ");
  ASSERT_NE(at, std::string::npos) << text;
  EXPECT_NEAR(std::stod(text.substr(at + 22)), 0.25, 1e-6) << text;
  // A mesh against a particle cache: one line, exit 2.
  writeParticleFrame(dir / "p.vdb", lattice(10));
  const fs::path bad = dir / "bad.log";
  EXPECT_EQ(test::run({"inspect", (dir / "a.obj").string(), "--against", (dir / "p.vdb").string()}, bad), 2);
  const std::string line = test::readLog(bad);
  EXPECT_EQ(line.find('\n'), line.size() - 1) << line;
  EXPECT_NE(line.find("a mesh and a particle cache do not compare"), std::string::npos) << line;
}
