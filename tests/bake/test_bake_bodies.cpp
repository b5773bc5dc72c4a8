// Bakes with moving solids: a crate dropped into a pool, killed with
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
#include <sstream>
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
fs::path writeScene(const std::string& name, const std::string& obstacle = "",
                    const std::string& probes = R"([{"name": "B", "type": "body", "obstacle": "crate"}, )"
                                                R"({"name": "U", "type": "velocity", "at": [0.05, 0.05, 0.05]}])") {
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
  "probes": )" << probes << R"(
})";
  return file;
}

std::uint64_t checksumOf(const fs::path& file) { return particleChecksum(readParticleFrame(file)); }
} // namespace

/// Bakes `scene` whole into NAME_reference, and again into NAME_killed killed with
/// SIGKILL once frame 5 is written, then resumed: every frame's particles and solids,
/// and the probes, must be bit for bit the reference's.
void expectResumeIsBitIdentical(const fs::path& scene, const std::string& name) {
  const fs::path reference = scratch() / (name + "_reference"), killed = scratch() / (name + "_killed");
  const fs::path referenceLog = scratch() / (name + "_reference.log"), killedLog = scratch() / (name + "_killed.log"),
                 resumeLog = scratch() / (name + "_resume.log");
  ASSERT_EQ(waitFor(spawn({"bake", scene.string(), "-o", reference.string()}, referenceLog)), 0) << readLog(referenceLog);
  const OutputLayout ref(reference), out(killed);
  const pid_t pid = spawn({"bake", scene.string(), "-o", killed.string()}, killedLog);
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (!fs::exists(out.particles(5)) && std::chrono::steady_clock::now() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  std::this_thread::sleep_for(std::chrono::milliseconds(40));
  ::kill(pid, SIGKILL);
  EXPECT_EQ(waitFor(pid), 128 + SIGKILL);
  ASSERT_FALSE(fs::exists(out.particles(12))) << "the bake finished before it could be killed";
  ASSERT_EQ(waitFor(spawn({"bake", scene.string(), "-o", killed.string()}, resumeLog)), 0) << readLog(resumeLog);
  EXPECT_NE(readLog(resumeLog).find("resuming"), std::string::npos);
  for (int frame = 1; frame <= 12; ++frame) {
    EXPECT_EQ(checksumOf(out.particles(frame)), checksumOf(ref.particles(frame))) << "frame " << frame;
    EXPECT_EQ(readTextFile(out.solids(frame)), readTextFile(ref.solids(frame))) << "frame " << frame;
  }
  EXPECT_EQ(readTextFile(out.probes()), readTextFile(ref.probes()));
}

TEST(BakeBodies, SigkillMidFrameThenResumeIsBitIdentical) {
  ASSERT_TRUE(fs::exists(kCascade));
  const fs::path scene = writeScene("crate");
  expectResumeIsBitIdentical(scene, "crate");
  // The crate fell and the probes say so: its centre ends lower, and it moved.
  const OutputLayout ref(scratch() / "crate_reference");
  const std::string probes = readTextFile(ref.probes());
  EXPECT_EQ(probes.substr(0, probes.find('\n')), "t,B_x,B_y,B_z,B_vx,B_vy,B_vz,U_x,U_y,U_z");
  EXPECT_TRUE(fs::exists(ref.solids(12)));
  EXPECT_NE(readTextFile(ref.solids(1)), readTextFile(ref.solids(12)));
}

// WCSPH picks its kernels when it starts (solver.kernels "auto": the cubic spline with a
// floating body); a bake resumed from a checkpoint must pick the same ones.
TEST(BakeBodies, WcsphFloatingCrateResumesBitIdentical) {
  ASSERT_TRUE(fs::exists(kCascade));
  const fs::path scene = writeScene("crate_wcsph");
  std::string text = readTextFile(scene);
  const std::string dfsph = R"("type": "dfsph")";
  ASSERT_NE(text.find(dfsph), std::string::npos);
  text.replace(text.find(dfsph), dfsph.size(), R"("type": "wcsph")");
  std::ofstream(scene) << text;
  expectResumeIsBitIdentical(scene, "crate_wcsph");
}

TEST(BakeBodies, DeformingSequenceResumesBitIdentical) {
  // scenes/flex_paddle.json's bending paddle (an OBJ sequence) in the pool.
  const std::string paddle = R"({"name": "paddle", "mesh": ")" + kAssets +
                             R"(/flex_paddle/paddle.####.obj", "translate": [0.05, 0.15, 0.0]})";
  const fs::path scene =
      writeScene("paddle", paddle, R"([{"name": "F", "type": "force", "obstacle": "paddle"}, )"
                                   R"({"name": "U", "type": "velocity", "at": [0.1, 0.15, 0.06]}])");
  expectResumeIsBitIdentical(scene, "paddle");
  // The solids of each frame are the sequence's frames, placed: frame 12's paddle bends.
  const OutputLayout ref(scratch() / "paddle_reference");
  const TriangleMesh first = readObj(ref.solids(1)), last = readObj(ref.solids(12));
  const TriangleMesh file12 = readObj(kAssets + "/flex_paddle/paddle.0012.obj");
  ASSERT_EQ(last.groups.size(), 2u);  // the tank, the paddle
  const TriangleMesh::Group& group = last.groups[1];
  EXPECT_EQ(group.name, "paddle");
  float largest = 0;
  for (std::size_t t = group.begin; t < group.end; ++t)
    for (const std::uint32_t v : last.triangles[t]) {
      // Every paddle vertex of frame 12 is a vertex of the file, placed by the translation.
      float nearest = 1e9f;
      for (const Eigen::Vector3f& w : file12.vertices)
        nearest = std::min(nearest, (last.vertices[v] - (w + Eigen::Vector3f(0.05f, 0.15f, 0.0f))).norm());
      largest = std::max(largest, nearest);
    }
  EXPECT_LT(largest, 1e-6f);
  EXPECT_NE(readTextFile(ref.solids(1)), readTextFile(ref.solids(12)));
}

TEST(BakeBodies, ACrateDroppedOnAFloatingCrateDoesNotPassThroughIt) {
  // Two crates of density 600 in the pool: one floating, one dropped onto it from 10 cm.
  // In no frame does a vertex of either lie inside the other (1 mm allowed), and the
  // upper ends above the lower.
  const std::string crate = kAssets + "/crate.obj";
  const fs::path scene = writeScene(
      "stack",
      R"({"name": "crate", "mesh": ")" + crate + R"(", "translate": [0.15, 0.15, 0.13], "dynamic": {"density": 600}},
         {"name": "upper", "mesh": ")" + crate + R"(", "translate": [0.16, 0.14, 0.30], "rotate": [0, 0, 10], "dynamic": {"density": 600}})",
      R"([{"name": "L", "type": "body", "obstacle": "crate"}, {"name": "U", "type": "body", "obstacle": "upper"}])");
  const fs::path out = scratch() / "stack";
  const fs::path log = scratch() / "stack.log";
  ASSERT_EQ(waitFor(spawn({"bake", scene.string(), "-o", out.string()}, log)), 0) << readLog(log);
  const OutputLayout layout(out);
  // Each crate's box in its own frame: the inside test of a box given its 8 corners.
  const auto inside = [](const TriangleMesh& mesh, const TriangleMesh::Group& box, const Eigen::Vector3f& p) {
    std::vector<Eigen::Vector3f> corners;
    for (std::size_t t = box.begin; t < box.end; ++t)
      for (std::uint32_t v : mesh.triangles[t]) corners.push_back(mesh.vertices[v]);
    Eigen::Vector3f centre = Eigen::Vector3f::Zero();
    for (const auto& c : corners) centre += c / float(corners.size());
    // Inside by more than 1 mm: in front of no face plane grown by -1 mm.
    for (std::size_t t = box.begin; t < box.end; ++t) {
      const auto& tri = mesh.triangles[t];
      Eigen::Vector3f n = (mesh.vertices[tri[1]] - mesh.vertices[tri[0]]).cross(mesh.vertices[tri[2]] - mesh.vertices[tri[0]]);
      n.normalize();
      if (n.dot(centre - mesh.vertices[tri[0]]) > 0) n = -n;  // outward
      if (n.dot(p - mesh.vertices[tri[0]]) > -0.001f) return false;
    }
    return true;
  };
  for (int frame = 1; frame <= 12; ++frame) {
    const TriangleMesh solids = readObj(layout.solids(frame));
    ASSERT_EQ(solids.groups.size(), 3u);  // tank, crate, upper
    const TriangleMesh::Group &lower = solids.groups[1], &upper = solids.groups[2];
    int overlaps = 0;
    for (std::size_t t = upper.begin; t < upper.end; ++t)
      for (std::uint32_t v : solids.triangles[t]) overlaps += inside(solids, lower, solids.vertices[v]) ? 1 : 0;
    for (std::size_t t = lower.begin; t < lower.end; ++t)
      for (std::uint32_t v : solids.triangles[t]) overlaps += inside(solids, upper, solids.vertices[v]) ? 1 : 0;
    EXPECT_EQ(overlaps, 0) << "frame " << frame;
  }
  const std::string probes = readTextFile(layout.probes());
  const std::string last = probes.substr(probes.rfind('\n', probes.size() - 2) + 1);
  std::vector<double> values;
  std::stringstream row(last);
  for (std::string cell; std::getline(row, cell, ',');) values.push_back(std::stod(cell));
  ASSERT_EQ(values.size(), 13u);  // t, L_x .. L_vz, U_x .. U_vz
  EXPECT_GT(values[9], values[3] + 0.05);  // the upper's centre above the lower's
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
  const auto bake = [&](const std::string& name, const std::string& obstacle, const std::string& probes = "") {
    const fs::path log = scratch() / (name + ".log");
    const fs::path scene = probes.empty() ? writeScene(name, obstacle) : writeScene(name, obstacle, probes);
    const int status = waitFor(spawn({"bake", scene.string(), "-o", (scratch() / name).string()}, log));
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
  // A deforming sequence with a missing frame: the file and the path are named.
  fs::create_directories(scratch() / "short");
  for (int k = 1; k <= 11; ++k)
    fs::copy_file(kAssets + "/flex_paddle/paddle." + std::string(k < 10 ? "000" : "00") + std::to_string(k) + ".obj",
                  scratch() / "short" / ("paddle." + std::string(k < 10 ? "000" : "00") + std::to_string(k) + ".obj"),
                  fs::copy_options::overwrite_existing);
  std::tie(status, message) = bake("short", R"({"name": "paddle", "mesh": ")" + (scratch() / "short").string() +
                                                R"(/paddle.####.obj", "translate": [0.05, 0.15, 0.0]})",
                                        "[]");
  EXPECT_EQ(status, 2);
  EXPECT_NE(message.find("short.json: boundaries.obstacles[0].mesh: frame 12 of the mesh sequence is missing: " +
                         (scratch() / "short" / "paddle.0012.obj").string() + " (the bake runs to frame 12)"),
            std::string::npos)
      << message;
}
