// Every file Cascade writes names the version that wrote it (Version.h): the
// particle cache's VDB metadata, the OBJ and PLY headers.
#include "TestTempDir.h"
#include "libsph/Version.h"
#include "libsph/io/ParticleCache.h"
#include "libsph/io/TriangleMesh.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

using namespace cascade;
namespace fs = std::filesystem;

namespace {
/// The first `bytes` bytes of a file (its header).
std::string head(const fs::path& path, std::size_t bytes = 400) {
  std::ifstream in(path, std::ios::binary);
  std::string text(bytes, '\0');
  in.read(text.data(), std::streamsize(bytes));
  text.resize(std::size_t(in.gcount()));
  return text;
}
} // namespace

TEST(VersionStamps, EveryWriterRecordsTheVersion) {
  const std::string version = cascadeVersion();
  EXPECT_EQ(version.rfind(CASCADE_PROJECT_VERSION, 0), 0u) << version;  // starts with CMake's project version
  const std::string line = "written by cascade " + version;
  const fs::path dir = cascade::test::freshTempDir("stamps");

  ParticleFrame frame;
  frame.position = {Vec3r(0, 0, 0), Vec3r(0.01f, 0, 0)};
  frame.spacing = 0.01f;
  writeParticleFrame(dir / "p.vdb", frame);
  EXPECT_EQ(readParticleFrame(dir / "p.vdb").metadata.at("cascade_version"), version);
  writeParticlePly(dir / "p.ply", frame);
  EXPECT_NE(head(dir / "p.ply").find("comment " + line + "\n"), std::string::npos);

  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  mesh.triangles = {{0, 1, 2}};
  writeObj(dir / "m.obj", mesh);
  EXPECT_NE(head(dir / "m.obj").find("\n# " + line + "\n"), std::string::npos);  // after the header's comments
  writePly(dir / "m.ply", mesh);
  EXPECT_NE(head(dir / "m.ply").find("\ncomment " + line + "\n"), std::string::npos);
  fs::remove_all(dir);
}
