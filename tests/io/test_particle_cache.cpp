#include "libsph/Errors.h"
#include "libsph/io/ParticleCache.h"
#include "libsph/io/AtomicFile.h"

#include "TestTempDir.h"

#include <gtest/gtest.h>
#include <chrono>

#include <fstream>
#include <random>

using namespace cascade;
namespace fs = std::filesystem;
using cascade::test::freshTempDir;

namespace {

ParticleFrame randomFrame(std::size_t count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> position(-0.5f, 1.5f), velocity(-4.0f, 4.0f), density(990.0f, 1010.0f);
  ParticleFrame frame;
  frame.spacing = 0.02f;
  frame.time = 1.25;
  for (std::size_t i = 0; i < count; ++i) {
    frame.position.emplace_back(position(rng), position(rng), position(rng));
    frame.velocity.emplace_back(velocity(rng), velocity(rng), velocity(rng));
    frame.id.push_back(ParticleId(count - i));  // ids not in index order
    frame.density.push_back(density(rng));
    frame.pressure.push_back(density(rng) * 10.0f);
  }
  return frame;
}

} // namespace

TEST(ParticleCache, VdbRoundTripWithinCodecPrecision) {
  const fs::path dir = freshTempDir("io_roundtrip");
  const ParticleFrame frame = randomFrame(5000, 1);
  const double voxelSize = 2.0 * frame.spacing;
  writeParticleFrame(dir / "particles.0001.vdb", frame);
  const ParticleFrame read = readParticleFrame(dir / "particles.0001.vdb");
  ASSERT_EQ(read.size(), frame.size());
  EXPECT_DOUBLE_EQ(read.time, frame.time);
  EXPECT_FLOAT_EQ(read.spacing, frame.spacing);
  ASSERT_EQ(read.id.size(), frame.size());
  std::vector<std::size_t> indexOfId(frame.size() + 1);
  for (std::size_t i = 0; i < frame.size(); ++i) indexOfId[frame.id[i]] = i;
  for (std::size_t k = 0; k < read.size(); ++k) {
    const std::size_t i = indexOfId[read.id[k]];
    // P: 16-bit fixed point within a voxel; v: half floats (11-bit mantissa).
    EXPECT_LE((read.position[k] - frame.position[i]).cwiseAbs().maxCoeff(), voxelSize / 65535.0 + 1e-6);
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(read.velocity[k][c], frame.velocity[i][c], std::abs(frame.velocity[i][c]) * 1e-3 + 1e-6);
    EXPECT_EQ(read.density[k], frame.density[i]);
    EXPECT_EQ(read.pressure[k], frame.pressure[i]);
  }
  fs::remove_all(dir);
}

TEST(ParticleCache, ChecksumFollowsIdsNotFileOrder) {
  ParticleFrame frame = randomFrame(100, 2);
  const auto sum = particleChecksum(frame);
  ParticleFrame reversed = frame;
  std::reverse(reversed.position.begin(), reversed.position.end());
  std::reverse(reversed.velocity.begin(), reversed.velocity.end());
  std::reverse(reversed.id.begin(), reversed.id.end());
  EXPECT_EQ(particleChecksum(reversed), sum);
  reversed.velocity[3].x() += 1e-3f;
  EXPECT_NE(particleChecksum(reversed), sum);
}

TEST(ParticleCache, SameStateWritesTheSameChecksum) {
  // Resumed bakes are compared by the checksum of their caches: writing the
  // same particle state twice must read back to identical values.
  const fs::path dir = freshTempDir("io_checksum");
  writeParticleFrame(dir / "a.vdb", randomFrame(777, 3));
  writeParticleFrame(dir / "b.vdb", randomFrame(777, 3));
  EXPECT_EQ(particleChecksum(readParticleFrame(dir / "b.vdb")),
            particleChecksum(readParticleFrame(dir / "a.vdb")));
  fs::remove_all(dir);
}

TEST(ParticleCache, EmptyFrameRoundTrips) {
  const fs::path dir = freshTempDir("io_empty");
  ParticleFrame empty;
  empty.spacing = 0.01f;
  writeParticleFrame(dir / "e.vdb", empty);
  EXPECT_EQ(readParticleFrame(dir / "e.vdb").size(), 0u);
  fs::remove_all(dir);
}

TEST(ParticleCache, BadFilesAreInputErrorsNamingTheFile) {
  const fs::path dir = freshTempDir("io_bad");
  writeParticleFrame(dir / "good.vdb", randomFrame(2000, 4));
  const auto size = fs::file_size(dir / "good.vdb");
  fs::copy_file(dir / "good.vdb", dir / "truncated.vdb");
  fs::resize_file(dir / "truncated.vdb", size / 2);
  fs::copy_file(dir / "good.vdb", dir / "nearly.vdb");
  fs::resize_file(dir / "nearly.vdb", size - 1);
  fs::copy_file(dir / "good.vdb", dir / "header.vdb");
  fs::resize_file(dir / "header.vdb", 20);
  std::ofstream(dir / "foreign.vdb") << "this is not a vdb file at all";
  std::ofstream(dir / "foreign.ply") << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n1\n2\n3\n";
  std::ofstream(dir / "short.ply") << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n";
  for (const char* name : {"missing.vdb", "truncated.vdb", "nearly.vdb", "header.vdb", "foreign.vdb", "foreign.ply", "short.ply"}) {
    try {
      readParticleFrame(dir / name);
      ADD_FAILURE() << name << " was read";
    } catch (const InputError& error) {
      EXPECT_NE(std::string(error.what()).find(name), std::string::npos) << error.what();
    }
  }
  fs::remove_all(dir);
}

// Found by fuzz_whitewater: OpenVDB allocates and zero-fills whatever metadata length a
// corrupt file claims before the read fails (70 s and 11 GiB for a 778-byte file).
// validateVdbFile checks every length against the file's size first.
TEST(ParticleCache, ACorruptMetadataLengthIsRefusedAtOnce) {
  const fs::path dir = freshTempDir("io_lengths");
  writeParticleFrame(dir / "good.vdb", randomFrame(100, 5));
  std::string bytes = readTextFile(dir / "good.vdb");
  // The length before the grid metadata name "cascade_version", made 3.9e9.
  const std::size_t name = bytes.find("cascade_version");
  ASSERT_NE(name, std::string::npos);
  ASSERT_EQ(bytes.substr(name - 4, 4), std::string("\x0f\0\0\0", 4));
  bytes.replace(name - 4, 4, std::string("\x06\x02\x01\xe9", 4));
  std::ofstream(dir / "corrupt.vdb", std::ios::binary) << bytes;
  const auto start = std::chrono::steady_clock::now();
  try {
    readParticleFrame(dir / "corrupt.vdb");
    ADD_FAILURE() << "corrupt.vdb was read";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("corrupt.vdb: corrupt OpenVDB file (metadata name of 3909157382 bytes"),
              std::string::npos)
        << error.what();
  }
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 5.0);
  fs::remove_all(dir);
}

TEST(ParticleCache, PlyBinaryAndAsciiRead) {
  const fs::path dir = freshTempDir("io_ply");
  const ParticleFrame frame = randomFrame(321, 5);
  writeParticlePly(dir / "p.ply", frame);
  const ParticleFrame binary = readParticleFrame(dir / "p.ply");
  ASSERT_EQ(binary.size(), frame.size());
  for (std::size_t i = 0; i < frame.size(); ++i) {
    EXPECT_EQ(binary.position[i], frame.position[i]);
    EXPECT_EQ(binary.velocity[i], frame.velocity[i]);
  }
  std::ofstream(dir / "a.ply") << "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n"
                                  "property float y\nproperty float z\nproperty uchar red\n"
                                  "element face 0\nproperty list uchar int vertex_indices\nend_header\n"
                                  "1 2 3 255\n-4 5.5 6 0\n";
  const ParticleFrame ascii = readParticleFrame(dir / "a.ply");
  ASSERT_EQ(ascii.size(), 2u);
  EXPECT_EQ(ascii.position[1], Vec3r(-4, 5.5f, 6));
  EXPECT_TRUE(ascii.velocity.empty());
  fs::remove_all(dir);
}
