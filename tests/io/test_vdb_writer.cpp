// writeVdbFile (libsph/io/VdbWriter.h): the bytes io::File::write gives, written
// through one buffer, and a failed write is an error, not a short file.
#include "libsph/io/AtomicFile.h"
#include "libsph/io/VdbWriter.h"

#include "TestTempDir.h"

#include <openvdb/io/File.h>
#include <openvdb/tools/LevelSetSphere.h>
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

using namespace cascade;
namespace fs = std::filesystem;

namespace {

/// A level set of a few thousand leaves and a half-float vector grid over its band.
openvdb::GridCPtrVec surfaceAndVelocity() {
  openvdb::initialize();
  auto surface = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(3.0f, openvdb::Vec3f(0.1f, -0.2f, 0.3f), 0.02f);
  surface->setName("surface");
  auto velocity = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.0f));
  velocity->setName("v");
  velocity->setTransform(surface->transform().copy());
  velocity->tree().topologyUnion(surface->tree());
  for (auto value = velocity->beginValueOn(); value; ++value) {
    const openvdb::Coord c = value.getCoord();
    value.setValue(openvdb::Vec3s(0.01f * float(c.x()), -0.5f, 0.25f * float(c.z() % 7)));
  }
  velocity->setSaveFloatAsHalf(true);
  return {surface, velocity};
}

/// The file's 36-character UUID (random per file) follows the magic number, the
/// versions and the grid-offsets flag (21 bytes).
std::string withoutUuid(std::string bytes) {
  if (bytes.size() > 57) bytes.replace(21, 36, 36, '-');
  return bytes;
}

TEST(VdbWriter, WritesTheBytesOpenVdbsFileWriterWrites) {
  const fs::path dir = test::freshTempDir("vdb_writer");
  const openvdb::GridCPtrVec grids = surfaceAndVelocity();
  const std::uint32_t activeMask = openvdb::io::COMPRESS_ACTIVE_MASK;
  for (std::uint32_t compression : {activeMask, activeMask | std::uint32_t(openvdb::io::COMPRESS_BLOSC)}) {
    openvdb::io::File reference((dir / "reference.vdb").string());
    reference.setCompression(compression);
    reference.write(grids);
    reference.close();
    writeVdbFile(dir / "buffered.vdb", grids, compression);
    const std::string expected = readTextFile(dir / "reference.vdb"), written = readTextFile(dir / "buffered.vdb");
    if (compression == activeMask) {  // flushed and seeked across buffers
      ASSERT_GT(expected.size(), std::size_t(8) << 20) << "smaller than one buffer";
    }
    EXPECT_EQ(withoutUuid(written), withoutUuid(expected)) << "compression " << compression;

    openvdb::io::File file((dir / "buffered.vdb").string());
    file.open();
    const auto v = openvdb::gridPtrCast<openvdb::Vec3SGrid>(file.readGrid("v"));
    file.close();
    ASSERT_TRUE(v);
    EXPECT_EQ(v->activeVoxelCount(), grids[1]->activeVoxelCount());
  }
}

TEST(VdbWriter, AFullDiskIsAnErrorNamingTheFile) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  const openvdb::GridCPtrVec grids = surfaceAndVelocity();
  try {
    writeVdbFile("/dev/full", grids, openvdb::io::COMPRESS_ACTIVE_MASK);
    FAIL() << "no error";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("/dev/full: cannot write"), std::string::npos) << error.what();
  }
}

TEST(VdbWriter, AnUnwritablePlaceIsAnErrorNamingTheFile) {
  const fs::path path = test::freshTempDir("vdb_writer_missing") / "no" / "such" / "dir.vdb";
  EXPECT_THROW(writeVdbFile(path, surfaceAndVelocity(), openvdb::io::COMPRESS_ACTIVE_MASK), std::runtime_error);
}

} // namespace
