// writeVdbFile (libsph/io/VdbWriter.h): the bytes io::File::write gives, written
// through one buffer, and a failed write is an error, not a short file.
#include "libsph/io/ActiveMaskLeafWriter.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/io/VdbWriter.h"

#include "TestTempDir.h"

#include <openvdb/io/File.h>
#include <openvdb/tools/LevelSetSphere.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <sstream>
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

/// The bytes of `leaf` on a stream set up as io::Archive sets it for a grid with
/// active-mask compression and this background: by OpenVDB's leaf writer, or by
/// writeActiveMaskLeaf (`fast` says whether it wrote them itself).
template <typename LeafT>
std::string leafBytes(const LeafT& leaf, const typename LeafT::ValueType& background, bool toHalf, bool ours,
                      bool* fast = nullptr) {
  std::ostringstream os(std::ios_base::binary);
  openvdb::io::setDataCompression(os, openvdb::io::COMPRESS_ACTIVE_MASK);
  openvdb::io::setGridBackgroundValuePtr(os, &background);
  if (ours) {
    const bool wrote = writeActiveMaskLeaf(os, leaf, background, toHalf);
    if (fast) *fast = wrote;
  } else {
    leaf.writeBuffers(os, toHalf);
  }
  return os.str();
}

/// Random leaves of every kind the writer meets: level-set leaves (inactive +-background
/// in runs or scattered), velocity leaves (inactive zero, also -0), all and no voxels
/// active, and leaves it must leave to OpenVDB (a third inactive value, NaN); active
/// values across the half range (subnormal, beyond 65504, infinite, signed zeros).
template <typename LeafT>
void checkRandomLeaves(typename LeafT::ValueType background, std::uint32_t seed) {
  using ValueT = typename LeafT::ValueType;
  std::mt19937 random(seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  const float specials[] = {0.0f, -0.0f, 1e-6f, -3e-8f, 6e-5f, 65504.0f, 65520.0f, -7e4f, 1e30f,
                            std::numeric_limits<float>::infinity(), 1.0f + 1.0f / 4096, 2049.0f};
  auto component = [&](bool special) {
    return special ? specials[random() % std::size(specials)] : (unit(random) - 0.5f) * 8.0f;
  };
  auto value = [&](bool special) {
    if constexpr (std::is_same_v<ValueT, float>) return component(special);
    else return ValueT(component(special), component(special), component(special));
  };
  int fastLeaves = 0, slowLeaves = 0;
  for (int trial = 0; trial < 600; ++trial) {
    LeafT leaf(openvdb::Coord(8 * (trial % 5), -8, 16), background, false);
    const int kind = trial % 6;  // 0-2: +-background inactive; 3: -0 for zero; 4: a third value; 5: NaN active
    const float density = std::array<float, 5>{0.0f, 0.1f, 0.5f, 0.9f, 1.0f}[std::size_t(trial / 6) % 5];
    const int split = int(random() % 512);
    for (openvdb::Index i = 0; i < LeafT::SIZE; ++i) {
      if (unit(random) < density) {
        leaf.setValueOn(i, value(random() % 4 == 0));
      } else {
        ValueT inactive = kind == 1 ? -background : background;  // all +background, all -background
        if (kind == 2 && int(i) >= split) inactive = -background;  // a level set: outside, then inside
        if (kind == 0 && random() % 2 == 0) inactive = -background;  // scattered
        if (kind == 3) inactive = -background;  // -0 where the background is 0: equal to it
        if (kind == 4 && i == openvdb::Index(split)) inactive = value(false);
        leaf.setValueOff(i, inactive);
      }
    }
    if (kind == 5 && leaf.onVoxelCount() > 0) leaf.setValueOn(leaf.beginValueOn().pos(), value(false) * std::nanf(""));
    for (bool toHalf : {false, true}) {
      bool fast = false;
      const std::string expected = leafBytes(leaf, background, toHalf, false);
      const std::string written = leafBytes(leaf, background, toHalf, true, &fast);
      ASSERT_EQ(written, expected) << "trial " << trial << " kind " << kind << " density " << density << " half "
                                   << toHalf;
      const bool otherInactive = kind == 4 && density < 1.0f && !leaf.isValueOn(openvdb::Index(split));
      const bool nanHalf = kind == 5 && toHalf && leaf.onVoxelCount() > 0;
      EXPECT_EQ(fast, !otherInactive && !nanHalf) << "trial " << trial << " kind " << kind;
      (fast ? fastLeaves : slowLeaves) += 1;
    }
  }
  EXPECT_GT(fastLeaves, 800);
  EXPECT_GT(slowLeaves, 100);
}

TEST(VdbWriter, LeavesAreWrittenAsOpenVdbWritesThem) {
  openvdb::initialize();
  checkRandomLeaves<openvdb::FloatTree::LeafNodeType>(0.06f, 1);        // a level set's background
  checkRandomLeaves<openvdb::FloatTree::LeafNodeType>(0.0f, 2);         // a fog volume's
  checkRandomLeaves<openvdb::Vec3STree::LeafNodeType>(openvdb::Vec3s(0.0f), 3);  // "v"
  checkRandomLeaves<openvdb::Vec3STree::LeafNodeType>(openvdb::Vec3s(1.0f, -2.0f, 0.5f), 4);
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
