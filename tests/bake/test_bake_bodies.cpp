// Bakes with moving solids (issue 16): a crate dropped into a pool, killed with
// SIGKILL mid-frame and resumed, ends with the same particles, body probe rows
// and per-frame solids as a bake never stopped; bad moving-solid input exits 2
// with one line naming the file and the JSON path.
#include "CascadeProcess.h"
#include "TestTempDir.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/io/OutputLayout.h"
#include "libsph/io/ParticleCache.h"
#include "libsph/io/TriangleMesh.h"

#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>
#include <fcntl.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

using namespace cascade;
using namespace cascade::test;
namespace fs = std::filesystem;

namespace {
const std::string kCascade = std::string(CASCADE_BINARY_DIR) + "/cascade";
const std::string kAssets = std::string(CASCADE_SOURCE_DIR) + "/scenes/assets";

const fs::path& scratch() {
  static const fs::path base = cascade::test::freshTempDir("bake_bodies");
  return base;
}

/// A 0.1 m crate of density 600 dropped from 5 cm above a pool 0.12 m deep (DFSPH,
/// 1.5 cm: 3,200 particles, 12 frames), a body probe and a velocity probe.
/// `obstacle` replaces the crate's JSON when given.
fs::path writeScene(const std::string& name, const std::string& obstacle = "") {
  const fs::path file = scratch() / (name + ".json");
  const std::string crate = obstacle.empty() ? R"({"name": "crate", "mesh": ")" + kAssets +
                                                   R"(/crate.obj", "translate": [0.15, 0.15, 0.22], "rotate": [0, 0, 20],
        "dynamic": {"density": 600}})"
                                             : obstacle;
  std::ofstream(file) << R"({
  "name": ")" << name << R"(",
  "fluid": {"spacing": 0.015, "blocks": [{"min": [0, 0, 0], "max": [0.3, 0.3, 0.12]}]},
  "solver": {"type": "dfsph"},
  "boundaries": {"tank": {"min": [0, 0, 0], "max": [0.3, 0.3, 0.4]}, "obstacles": [)" << crate << R"(]},
  "output": {"fps": 30, "end_time": 0.4, "probe_rate": 60},
  "probes": [{"name": "B", "type": "body", "obstacle": "crate"}, {"name": "U", "type": "velocity", "at": [0.05, 0.05, 0.05]}]
})";
  return file;
}

std::uint64_t checksumOf(const fs::path& file) { return particleChecksum(readParticleFrame(file)); }
} // namespace

TEST(BakeBodies, SigkillMidFrameThenResumeIsBitIdentical) {
  ASSERT_TRUE(fs::exists(kCascade));
  const fs::path scene = writeScene("crate");
  const fs::path reference = scratch() / "reference", killed = scratch() / "killed";
  ASSERT_EQ(waitFor(spawn({"bake", scene.string(), "-o", reference.string()}, scratch() / "reference.log")), 0)
      << readLog(scratch() / "reference.log");
  const OutputLayout ref(reference), out(killed);
  // The crate fell and the probes say so: its centre ends lower, and it moved.
  const std::string probes = readTextFile(ref.probes());
  ASSERT_EQ(probes.substr(0, probes.find('\n')), "t,B_x,B_y,B_z,B_vx,B_vy,B_vz,U_x,U_y,U_z");
  EXPECT_TRUE(fs::exists(ref.solids(12)));
  EXPECT_NE(readTextFile(ref.solids(1)), readTextFile(ref.solids(12)));

  const pid_t pid = spawn({"bake", scene.string(), "-o", killed.string()}, scratch() / "killed.log");
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (!fs::exists(out.particles(5)) && std::chrono::steady_clock::now() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  std::this_thread::sleep_for(std::chrono::milliseconds(40));
  ::kill(pid, SIGKILL);
  EXPECT_EQ(waitFor(pid), 128 + SIGKILL);
  ASSERT_FALSE(fs::exists(out.particles(12))) << "the bake finished before it could be killed";
  ASSERT_EQ(waitFor(spawn({"bake", scene.string(), "-o", killed.string()}, scratch() / "resume.log")), 0)
      << readLog(scratch() / "resume.log");
  EXPECT_NE(readLog(scratch() / "resume.log").find("resuming"), std::string::npos);
  for (int frame = 1; frame <= 12; ++frame) {
    EXPECT_EQ(checksumOf(out.particles(frame)), checksumOf(ref.particles(frame))) << "frame " << frame;
    EXPECT_EQ(readTextFile(out.solids(frame)), readTextFile(ref.solids(frame))) << "frame " << frame;
  }
  EXPECT_EQ(readTextFile(out.probes()), probes);
}

TEST(BakeBodies, BadMovingSolidInputExits2NamingThePath) {
  // An open box (its top missing) as a body with a density: its volume is unknown.
  TriangleMesh open;
  for (int k = 0; k < 8; ++k) open.vertices.emplace_back(float(k & 1) * 0.1f, float((k >> 1) & 1) * 0.1f, float(k >> 2) * 0.1f);
  const std::uint32_t faces[5][4] = {{0, 2, 3, 1}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : faces) {
    open.triangles.push_back({f[0], f[1], f[2]});
    open.triangles.push_back({f[0], f[2], f[3]});
  }
  writeObj(scratch() / "open.obj", open);
  const auto bake = [&](const std::string& name, const std::string& obstacle) {
    const fs::path log = scratch() / (name + ".log");
    const int status = waitFor(spawn({"bake", writeScene(name, obstacle).string(), "-o", (scratch() / name).string()}, log));
    return std::make_pair(status, readLog(log));
  };
  auto [status, message] = bake("open", R"({"name": "crate", "mesh": ")" + (scratch() / "open.obj").string() +
                                           R"(", "translate": [0.1, 0.1, 0.2], "dynamic": {"density": 600}})");
  EXPECT_EQ(status, 2);
  EXPECT_NE(message.find("open.obj: boundaries.obstacles[0].dynamic: the mesh is not closed"), std::string::npos) << message;
  // The same mesh with its mass given is baked (its holes filled for the inertia).
  std::tie(status, message) = bake("open_mass", R"({"name": "crate", "mesh": ")" + (scratch() / "open.obj").string() +
                                                    R"(", "translate": [0.1, 0.1, 0.2], "dynamic": {"mass": 0.5}})");
  EXPECT_EQ(status, 0) << message;
  // A crate that starts through the floor.
  std::tie(status, message) = bake("overlap", R"({"name": "crate", "mesh": ")" + kAssets +
                                                  R"(/crate.obj", "translate": [0.15, 0.15, 0.02], "dynamic": {"density": 600}})");
  EXPECT_EQ(status, 2);
  EXPECT_NE(message.find("boundaries.obstacles[0]: starts overlapping the solid \"tank\""), std::string::npos) << message;
  // Keyframes out of time order.
  std::tie(status, message) = bake("keys", R"({"name": "crate", "mesh": ")" + kAssets +
                                               R"(/crate.obj", "translate": [0.15, 0.15, 0.2], "motion": {"keyframes": [
        {"t": 0, "translate": [0, 0, 0]}, {"t": 0.5, "translate": [0, 0, 0.1]}, {"t": 0.2, "translate": [0, 0, 0]}]}})");
  EXPECT_EQ(status, 2);
  EXPECT_NE(message.find("keys.json: boundaries.obstacles[0].motion.keyframes[2].t: keyframes must be in increasing time order"),
            std::string::npos)
      << message;
}
