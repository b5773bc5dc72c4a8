// Probes and caches of a bake: the pressure probe of a tank at rest
// against rho g d; the probes.csv layout; the probe rate changes nothing but
// probes.csv; cache round trip of bake-like data within the codecs' stated
// precision (ParticleCache.h).
#include "TestTempDir.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/io/OutputLayout.h"
#include "libsph/io/ParticleCache.h"
#include "libsph/scene/Bake.h"
#include "libsph/scene/SceneJson.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <sstream>

using namespace cascade;
namespace fs = std::filesystem;

namespace {
/// Columns of probes.csv as numbers, by header name.
std::map<std::string, std::vector<double>> readCsv(const fs::path& file) {
  std::istringstream in(readTextFile(file));
  std::string line;
  std::getline(in, line);
  std::vector<std::string> names;
  std::stringstream header(line);
  for (std::string name; std::getline(header, name, ',');) names.push_back(name);
  std::map<std::string, std::vector<double>> columns;
  while (std::getline(in, line)) {
    std::stringstream row(line);
    std::string cell;
    for (std::size_t k = 0; k < names.size() && std::getline(row, cell, ','); ++k)
      columns[names[k]].push_back(std::stod(cell));
  }
  return columns;
}

double meanAfter(const std::map<std::string, std::vector<double>>& csv, const std::string& name, double t0) {
  const auto& t = csv.at("t");
  const auto& v = csv.at(name);
  double sum = 0;
  int n = 0;
  for (std::size_t i = 0; i < t.size(); ++i)
    if (t[i] >= t0) sum += v[i], ++n;
  return n ? sum / n : NAN;
}
} // namespace

TEST(BakeProbes, HydrostaticPressureFollowsRhoGD) {
  const fs::path out = cascade::test::freshTempDir("probe_hydrostatic") / "out";
  fs::remove_all(out);
  const scene::Scene scene = scene::loadScene(fs::path(CASCADE_SOURCE_DIR) / "scenes" / "hydrostatic.json",
                                              {"size=seed", "output.end_time=1.5", "output.fps=2"});
  scene::BakeOptions options;
  options.outDir = out;
  const scene::BakeResult result = scene::bakeScene(scene, options);
  ASSERT_TRUE(result.complete);
  const auto csv = readCsv(out / "probes.csv");
  ASSERT_EQ(csv.size(), 4u);  // t, P_floor, P_wall, H_centre
  EXPECT_EQ(csv.at("t").size(), 151u);  // 100 Hz over 1.5 s, t = 0 included

  // Settled (after 0.75 s), time averaged: p = rho g d at the floor (d = 0.2 m)
  // and half-way up the wall (d = 0.1 m).
  const double rhoG = scene.fluid.density * 9.81;
  const double floor = meanAfter(csv, "P_floor", 0.75);
  const double wall = meanAfter(csv, "P_wall", 0.75);
  const double height = meanAfter(csv, "H_centre", 0.75);
  std::printf("P_floor %.1f Pa (rho g d %.1f), P_wall %.1f Pa (rho g d %.1f), height %.4f m\n", floor,
              rhoG * 0.2, wall, rhoG * 0.1, height);
  EXPECT_NEAR(height, 0.2, 0.02);
  EXPECT_NEAR(floor, rhoG * 0.2, 0.15 * rhoG * 0.2);
  EXPECT_NEAR(wall, rhoG * 0.1, 0.15 * rhoG * 0.1);
  fs::remove_all(out);
}

TEST(BakeProbes, ProbeHeaderNamesForceComponents) {
  scene::Scene scene;
  scene.probes = {{"F", "force", {0, 0, 0}, "tower", {1, 0, 0}}, {"H", "height", {0, 0, 0}, "", {1, 0, 0}}};
  EXPECT_EQ(scene::probeHeader(scene), "t,F_x,F_y,F_z,H\n");
}

TEST(BakeProbes, CacheRoundTripWithinCodecPrecision) {
  // Bake-like data: 20,000 particles in a 2 m tank, speeds up to 6 m/s.
  std::mt19937 random(7);
  std::uniform_real_distribution<float> unit(0.f, 1.f);
  ParticleFrame frame;
  frame.spacing = 0.01f;
  frame.time = 0.7;
  for (int i = 0; i < 20000; ++i) {
    frame.position.emplace_back(2 * unit(random) - 1, unit(random), 0.5f * unit(random));
    frame.velocity.emplace_back(12 * unit(random) - 6, 2 * unit(random) - 1, 6 * unit(random) - 3);
    frame.id.push_back(ParticleId(19999 - i));
    frame.density.push_back(990 + 20 * unit(random));
    frame.pressure.push_back(5000 * unit(random));
  }
  const fs::path file = cascade::test::freshTempDir("probe_cache") / "particles.vdb";
  writeParticleFrame(file, frame);
  const ParticleFrame read = readParticleFrame(file);
  ASSERT_EQ(read.size(), frame.size());
  std::map<ParticleId, std::size_t> byId;
  for (std::size_t i = 0; i < read.size(); ++i) byId[read.id[i]] = i;
  ASSERT_EQ(byId.size(), frame.size());
  // P: 16-bit fixed point within a voxel of 2 spacings -> 0.02 / 65536 m (+ float rounding).
  const double positionBound = 0.02 / 65536 + 1e-6;
  // v: half floats, relative precision 2^-11.
  double worstPosition = 0, worstVelocity = 0;
  for (std::size_t i = 0; i < frame.size(); ++i) {
    const std::size_t k = byId.at(frame.id[i]);
    worstPosition = std::max(worstPosition, double((read.position[k] - frame.position[i]).cwiseAbs().maxCoeff()));
    for (int c = 0; c < 3; ++c)
      worstVelocity = std::max(worstVelocity, std::abs(double(read.velocity[k][c] - frame.velocity[i][c])) /
                                                  std::max(1e-3, std::abs(double(frame.velocity[i][c]))));
    EXPECT_EQ(read.density[k], frame.density[i]);
    EXPECT_EQ(read.pressure[k], frame.pressure[i]);
  }
  EXPECT_LE(worstPosition, positionBound);
  EXPECT_LE(worstVelocity, std::ldexp(1.0, -11));
  EXPECT_EQ(read.time, frame.time);
  fs::remove(file);
}

// Probes are read, never steered to: a probe time inside a step reads the probes at
// the step's ends, interpolated, so the probe rate changes probes.csv and nothing
// else. DFSPH (whose steps shortened to land on probe times changed the water's
// pressure) on the dam break at 64 Hz and 1024 Hz (exact binary intervals): the same
// caches bit for bit, and every 64 Hz row is the 1024 Hz row of the same time.
TEST(BakeProbes, TheProbeRateChangesOnlyTheProbesFile) {
  const fs::path dir = cascade::test::freshTempDir("probe_rate");
  std::map<int, std::vector<std::string>> rows;
  for (int rate : {64, 1024}) {
    const fs::path out = dir / std::to_string(rate);
    const scene::Scene scene = scene::loadScene(
        fs::path(CASCADE_SOURCE_DIR) / "scenes" / "dambreak.json",
        {"size=seed", "solver.type=dfsph", "output.fps=16", "output.end_time=0.1875",
         "output.probe_rate=" + std::to_string(rate)});
    scene::BakeOptions options;
    options.outDir = out;
    ASSERT_TRUE(scene::bakeScene(scene, options).complete);
    std::istringstream in(readTextFile(out / "probes.csv"));
    for (std::string line; std::getline(in, line);) rows[rate].push_back(line);
  }
  for (int frame = 1; frame <= 3; ++frame) {
    const ParticleFrame a = readParticleFrame(OutputLayout(dir / "64").particles(frame));
    const ParticleFrame b = readParticleFrame(OutputLayout(dir / "1024").particles(frame));
    ASSERT_EQ(a.size(), b.size()) << "frame " << frame;
    EXPECT_EQ(a.time, b.time) << "frame " << frame;
    for (std::size_t i = 0; i < a.size(); ++i) {
      ASSERT_EQ(a.position[i], b.position[i]) << "frame " << frame << ", particle " << i;
      ASSERT_EQ(a.velocity[i], b.velocity[i]) << "frame " << frame << ", particle " << i;
    }
  }
  // Header plus 0.1875 s at each rate, t = 0 included.
  ASSERT_EQ(rows[64].size(), 1u + 13u);
  ASSERT_EQ(rows[1024].size(), 1u + 193u);
  EXPECT_EQ(rows[64][0], rows[1024][0]);
  for (std::size_t k = 1; k < rows[64].size(); ++k) EXPECT_EQ(rows[64][k], rows[1024][1 + 16 * (k - 1)]) << "row " << k;
  // The front moves between frames: the rows are the water's, not a held value.
  EXPECT_NE(rows[1024][100].substr(rows[1024][100].find(',')), rows[1024][101].substr(rows[1024][101].find(',')));
  fs::remove_all(dir);
}
