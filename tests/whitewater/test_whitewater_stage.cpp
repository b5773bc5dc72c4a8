// The whitewater stage end to end through the built `cascade` program: still
// water, where spray is born in a splash, determinism and SIGKILL resume, bad
// input, `cascade inspect`, `cascade run` skipping, and the preview drawing it.
#include "WhitewaterTestFluids.h"
#include "TestTempDir.h"
#include "bake/CascadeProcess.h"

#include "libsph/io/OutputLayout.h"
#include "libsph/search/UniformGridSearch.h"
#include "render/Image.h"
#include "surfacing/FoamDensity.h"
#include "whitewater/FluidInterval.h"
#include "whitewater/Potentials.h"
#include "whitewater/WhitewaterFile.h"
#include "whitewater/WhitewaterSolver.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <signal.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <thread>
#include <tuple>

using namespace cascade;
using namespace cascade::whitewater;
namespace fs = std::filesystem;

namespace {

const std::string kScenes = std::string(CASCADE_SOURCE_DIR) + "/scenes";

fs::path scratch() {
  static const fs::path base = test::freshTempDir("whitewater_stage");
  return base;
}

/// The tower scene at seed size, baked once for the tests of this file.
const fs::path& towerBake() {
  static const fs::path out = [] {
    const fs::path dir = scratch() / "tower";
    const int status = test::run({"bake", kScenes + "/tower.json", "--set", "size=seed", "-o", dir.string()},
                                 scratch() / "tower_bake.log");
    EXPECT_EQ(status, 0) << test::readLog(scratch() / "tower_bake.log");
    return dir;
  }();
  return out;
}

/// A copy of a bake (particles and scene.json) to run whitewater in.
fs::path copyOf(const fs::path& bake, const std::string& name) {
  const fs::path dir = scratch() / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  fs::copy(bake / "particles", dir / "particles", fs::copy_options::recursive);
  fs::copy(bake / "scene.json", dir / "scene.json");
  return dir;
}

std::vector<std::uint64_t> checksums(const fs::path& out, int frames) {
  std::vector<std::uint64_t> sums;
  for (int frame = 1; frame <= frames; ++frame)
    sums.push_back(whitewaterChecksum(readWhitewaterVdb(OutputLayout(out).whitewater(frame))));
  return sums;
}

int frameCount(const fs::path& out) { return int(listFrames(OutputLayout(out).particlesDir(), "particles", "vdb").size()); }

} // namespace

TEST(WhitewaterStage, StillWaterMakesNoWhitewaterOverTwoSeconds) {
  const fs::path out = scratch() / "still";
  ASSERT_EQ(test::run({"bake", kScenes + "/hydrostatic.json", "--set", "size=seed", "--set", "output.end_time=2",
                       "-o", out.string()},
                      scratch() / "still_bake.log"),
            0)
      << test::readLog(scratch() / "still_bake.log");
  for (const std::string limits : {"auto", "fixed"}) {
    const fs::path log = scratch() / ("still_" + limits + ".log");
    ASSERT_EQ(test::run({"whitewater", out.string(), "--limits", limits, "--force"}, log), 0) << test::readLog(log);
    const int frames = frameCount(out);
    ASSERT_EQ(frames, 60);
    std::size_t total = 0;
    for (int frame = 1; frame <= frames; ++frame)
      total += readWhitewaterVdb(OutputLayout(out).whitewater(frame)).particles.size();
    EXPECT_EQ(total, 0u) << limits << " limits\n" << test::readLog(log);
  }
}

TEST(WhitewaterStage, SprayIsBornWhereTrappedAirOrCrestsAreHighest) {
  // The tower splash, stepped in eighths of a frame so that each birth is seen
  // where it happens: a particle born in a step sits at its birth place at the
  // step's end (births follow the advection). Every particle that is spray at
  // some frame is judged by its birth place: within 2 support radii of a fluid
  // particle whose trapped-air or crest potential (of the frame it was born in)
  // is in that frame's top decile, at the step's start?
  const fs::path& bake = towerBake();
  const OutputLayout layout(bake);
  scene::WhitewaterSettings settings;
  settings.substeps = 1;
  constexpr int kSteps = 8;
  DiffuseParticles diffuse;
  std::uint32_t nextId = 0;
  std::vector<std::uint8_t> bornNearHot, everSpray;
  std::size_t fluidNear = 0, fluidAll = 0;  // the same test for the fluid particles: the baseline
  const int frames = frameCount(bake);
  for (int frame = 1; frame < frames; ++frame) {
    const ParticleFrame a = readParticleFrame(layout.particles(frame)), b = readParticleFrame(layout.particles(frame + 1));
    const Real h = 2 * a.spacing;
    WhitewaterSolver solver(settings, Vec3r(0, 0, Real(-9.81)), a.spacing, RemovalBox{});
    std::vector<Vec3r> x, v;
    fluidArrays(a, x, v, "a");
    search::UniformGridSearch grid;
    NeighborLists lists;
    grid.findNeighbors(x.data(), x.size(), h, lists);
    const FluidPotentials potentials = computePotentials(x, v, lists, h);
    const auto decile = [](std::vector<float> values) {
      std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(values.size() * 9 / 10), values.end());
      return values[values.size() * 9 / 10];
    };
    const float topAir = decile(potentials.trappedAir), topCrest = decile(potentials.waveCrest);
    std::vector<std::uint8_t> hot(a.size(), 0);
    for (std::size_t i = 0; i < a.size(); ++i)
      hot[i] = (topAir > 0 && potentials.trappedAir[i] >= topAir) || (topCrest > 0 && potentials.waveCrest[i] >= topCrest);
    const std::vector<float> rates = birthRates(potentials, limitsFromStatistics({potentials}, physicalFloors(h, 9.81)),
                                                settings.trappedAirRate, settings.waveCrestRate, 1);
    const FluidInterval interval(a, b, a.time, b.time, "a");
    const double dt = (b.time - a.time) / kSteps;
    ParticleFrame start = a;
    for (int step = 0; step < kSteps; ++step) {
      ParticleFrame end = a;
      interval.at(a.time + (step + 1) * dt, end.position, end.velocity);
      end.time = a.time + (step + 1) * dt;
      std::vector<Vec3r> hotPlaces;
      for (std::size_t i = 0; i < start.size(); ++i)
        if (hot[i]) hotPlaces.push_back(start.position[i]);
      const std::uint32_t firstNew = nextId;
      solver.advance(FluidInterval(start, end, start.time, end.time, "a"), rates, frame * kSteps + step, diffuse, nextId);
      bornNearHot.resize(nextId, 0);
      everSpray.resize(nextId, 0);
      if (!hotPlaces.empty() && nextId > firstNew) {
        search::UniformGridSearch hotGrid;
        hotGrid.build(hotPlaces.data(), hotPlaces.size(), 2 * h);
        NeighborLists close;
        if (step == 0) {
          hotGrid.query(start.position.data(), start.size(), nullptr, false, close);
          for (std::size_t i = 0; i < start.size(); ++i) fluidNear += close.count(i) > 0;
          fluidAll += start.size();
        }
        hotGrid.query(diffuse.position.data(), diffuse.size(), nullptr, false, close);
        for (std::size_t i = 0; i < diffuse.size(); ++i)
          if (diffuse.id[i] >= firstNew) bornNearHot[diffuse.id[i]] = close.count(i) > 0;
      }
      start = end;
    }
    const std::vector<DiffuseType> types = solver.classify(diffuse, b.position);
    for (std::size_t i = 0; i < diffuse.size(); ++i)
      if (types[i] == DiffuseType::Spray) everSpray[diffuse.id[i]] = 1;
  }
  std::size_t spray = 0, near = 0;
  for (std::size_t id = 0; id < everSpray.size(); ++id) {
    spray += everSpray[id];
    near += everSpray[id] && bornNearHot[id];
  }
  ASSERT_GT(spray, 50u);
  const double fraction = double(near) / double(spray);
  const double baseline = double(fluidNear) / double(std::max<std::size_t>(fluidAll, 1));
  std::printf("spray born within 2 h of top-decile particles: %zu of %zu (%.1f %%), %u diffuse born in all; "
              "fluid particles that near, in the frames with births: %.1f %%\n",
              near, spray, 100 * fraction, nextId, 100 * baseline);
  EXPECT_GT(fraction, 0.8);
}

TEST(WhitewaterStage, RunsAreIdenticalAndAKilledRunResumesToTheSameFiles) {
  const fs::path out = copyOf(towerBake(), "determinism");
  const int frames = frameCount(out);
  // Enough sub-steps that the run lasts long enough to be killed in the middle.
  const std::vector<std::string> options{"--substeps", "40"};
  auto args = [&](std::vector<std::string> extra) {
    std::vector<std::string> all{"whitewater", out.string()};
    all.insert(all.end(), options.begin(), options.end());
    all.insert(all.end(), extra.begin(), extra.end());
    return all;
  };
  ASSERT_EQ(test::run(args({}), scratch() / "det1.log"), 0) << test::readLog(scratch() / "det1.log");
  const std::vector<std::uint64_t> first = checksums(out, frames);
  ASSERT_EQ(test::run(args({"--force"}), scratch() / "det2.log"), 0);
  EXPECT_EQ(checksums(out, frames), first);
  std::size_t particles = 0;
  for (int frame = 1; frame <= frames; ++frame)
    particles += readWhitewaterHeader(OutputLayout(out).whitewater(frame)).nextId;
  EXPECT_GT(particles, 1000u);

  // Kill a forced run once a frame in the middle is rewritten, then run again.
  const fs::path middle = OutputLayout(out).whitewater(frames / 2);
  const auto before = fs::last_write_time(middle);
  const pid_t pid = test::spawn(args({"--force"}), scratch() / "det3.log");
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (fs::last_write_time(middle) == before && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ::kill(pid, SIGKILL);
  EXPECT_EQ(test::waitFor(pid), 128 + SIGKILL) << "the run ended before it could be killed";
  ASSERT_EQ(test::run(args({}), scratch() / "det4.log"), 0) << test::readLog(scratch() / "det4.log");
  EXPECT_NE(test::readLog(scratch() / "det4.log").find("kept"), std::string::npos);
  EXPECT_EQ(checksums(out, frames), first);
}

TEST(WhitewaterStage, AutomaticLimitsFromAnUnfinishedBakeAreSaidAndMadeAgainAfterIt) {
  // A run on a bake that is still going (its caches stop at frame 12) says that
  // its automatic limits come from part of the bake. Once the bake is whole, a
  // plain run makes the limits again and remakes every frame: the files equal
  // those of a run on the whole bake, and none of the earlier frames is kept.
  const fs::path whole = copyOf(towerBake(), "limits_whole");
  const int frames = frameCount(whole);
  ASSERT_GT(frames, 20);
  ASSERT_EQ(test::run({"whitewater", whole.string()}, scratch() / "limits_whole.log"), 0)
      << test::readLog(scratch() / "limits_whole.log");
  EXPECT_EQ(test::readLog(scratch() / "limits_whole.log").find("not finished"), std::string::npos);

  const fs::path growing = copyOf(towerBake(), "limits_growing");
  const fs::path later = scratch() / "limits_later";
  fs::remove_all(later);
  fs::create_directories(later);
  const OutputLayout layout(growing);
  for (int frame = 13; frame <= frames; ++frame)
    fs::rename(layout.particles(frame), later / layout.particles(frame).filename());
  const fs::path partialLog = scratch() / "limits_partial.log";
  ASSERT_EQ(test::run({"whitewater", growing.string()}, partialLog), 0) << test::readLog(partialLog);
  const std::string partial = test::readLog(partialLog);
  EXPECT_NE(partial.find("the bake is not finished (caches up to frame 12 of " + std::to_string(frames) + ")"),
            std::string::npos)
      << partial;
  const auto limitsFile = [&] { return nlohmann::json::parse(std::ifstream(layout.whitewaterDir() / "limits.json")); };
  EXPECT_EQ(limitsFile()["cached_frames"], nlohmann::json({1, 12, 12}));
  const std::vector<std::uint64_t> early = checksums(growing, 12);

  for (int frame = 13; frame <= frames; ++frame)
    fs::rename(later / layout.particles(frame).filename(), layout.particles(frame));
  const fs::path afterLog = scratch() / "limits_after.log";
  ASSERT_EQ(test::run({"whitewater", growing.string()}, afterLog), 0) << test::readLog(afterLog);
  const std::string after = test::readLog(afterLog);
  EXPECT_EQ(after.find("not finished"), std::string::npos) << after;
  EXPECT_EQ(after.find("kept"), std::string::npos) << after;
  EXPECT_EQ(limitsFile()["cached_frames"], nlohmann::json({1, frames, frames}));
  const std::vector<std::uint64_t> final = checksums(growing, frames);
  EXPECT_EQ(final, checksums(whole, frames));
  // The limits did change: frames made with part of the bake's were not right.
  EXPECT_NE(std::vector<std::uint64_t>(final.begin(), final.begin() + 12), early);
}

TEST(WhitewaterStage, RatesPerAreaOrVolumeAreThePerParticleRatesTimesTheSpacingRatioSquaredOrCubed) {
  // reference_spacing twice the bake's spacing: a particle holds (1/2)^2 of the
  // reference's surface and (1/2)^3 of its water, so it gives birth at 1/4 or
  // 1/8 of the rates. The particles equal, bit for bit, those of rate_scale 1/4
  // or 1/8 (the factors are exact in binary), and not those of the per-particle
  // default.
  const fs::path perParticle = copyOf(towerBake(), "per_particle");
  const int frames = frameCount(perParticle);
  const double spacing = readParticleFrame(OutputLayout(perParticle).particles(1)).spacing;
  ASSERT_GT(spacing, 0);
  ASSERT_EQ(test::run({"whitewater", perParticle.string()}, scratch() / "per_particle.log"), 0);
  const auto births = [&](const fs::path& out) {
    return readWhitewaterHeader(OutputLayout(out).whitewater(frames)).nextId;
  };
  ASSERT_GT(births(perParticle), 1000u);
  char reference[64];
  std::snprintf(reference, sizeof reference, "%.17g", 2 * spacing);
  for (const auto& [per, scale, words] :
       {std::tuple{"area", "0.25", "rates per area of water surface: x 0.25"},
        std::tuple{"volume", "0.125", "rates per volume of water: x 0.125"}}) {
    const std::string name = std::string("per_") + per;
    const fs::path out = copyOf(towerBake(), name);
    const fs::path log = scratch() / (name + ".log");
    ASSERT_EQ(test::run({"whitewater", out.string(), "--rates-per", per, "--reference-spacing", reference}, log), 0)
        << test::readLog(log);
    EXPECT_NE(test::readLog(log).find(words), std::string::npos) << test::readLog(log);
    const fs::path scaled = copyOf(towerBake(), name + "_scaled");
    ASSERT_EQ(test::run({"whitewater", scaled.string(), "--rate-scale", scale}, scratch() / (name + "_scaled.log")), 0);
    EXPECT_EQ(checksums(out, frames), checksums(scaled, frames)) << per;
    EXPECT_NEAR(double(births(out)) / double(births(perParticle)), std::stod(scale), std::stod(scale) * 0.2) << per;

    // The keys in a scene's block do the same.
    const fs::path fromScene = copyOf(towerBake(), name + "_scene");
    nlohmann::json scene = nlohmann::json::parse(std::ifstream(fromScene / "scene.json"));
    scene["whitewater"]["rates_per"] = per;
    scene["whitewater"]["reference_spacing"] = 2 * spacing;
    std::ofstream(fromScene / "scene.json") << scene.dump();
    ASSERT_EQ(test::run({"whitewater", fromScene.string()}, scratch() / (name + "_scene.log")), 0);
    EXPECT_EQ(checksums(fromScene, frames), checksums(scaled, frames)) << per;
  }

  // A spacing that would do nothing, or none where one is needed: bad input.
  const auto expectBad = [&](const std::vector<std::string>& args, const std::string& words) {
    const fs::path log = scratch() / "per_bad.log";
    EXPECT_EQ(test::run(args, log), 2) << test::readLog(log);
    EXPECT_NE(test::readLog(log).find(words), std::string::npos) << test::readLog(log);
  };
  expectBad({"whitewater", perParticle.string(), "--reference-spacing", reference},
            "--reference-spacing: has no effect with rates per particle");
  expectBad({"whitewater", perParticle.string(), "--rates-per", "area"}, "--rates-per: \"area\" needs reference_spacing");
  expectBad({"whitewater", perParticle.string(), "--rates-per", "volume", "--reference-spacing", "-0.01"},
            "--reference-spacing: must be >= 0");
}

TEST(WhitewaterStage, BadInputIsOneLineAndExitTwo) {
  const fs::path out = copyOf(towerBake(), "bad");
  const auto expectBad = [&](const std::vector<std::string>& args, const std::string& words) {
    const fs::path log = scratch() / "bad.log";
    EXPECT_EQ(test::run(args, log), 2) << test::readLog(log);
    const std::string text = test::readLog(log);
    EXPECT_NE(text.find(words), std::string::npos) << text;
    EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 1) << text;
  };
  expectBad({"whitewater", out.string(), "--rate-scale", "-1"}, "--rate-scale: must be >= 0");
  expectBad({"whitewater", out.string(), "--lifetime", "5,2"}, "--lifetime: min must be <= max");
  expectBad({"whitewater", out.string(), "--frames", "200-210"}, "frame");
  expectBad({"whitewater", out.string(), "--limits", "sometimes"}, "--limits: must be one of");
  EXPECT_FALSE(fs::exists(OutputLayout(out).whitewater(1)));

  // A scene file whose block is wrong is named.
  nlohmann::json scene = nlohmann::json::parse(std::ifstream(out / "scene.json"));
  scene["whitewater"] = {{"trapped_air_rate", -5}};
  std::ofstream(out / "scene.json") << scene.dump();
  expectBad({"whitewater", out.string()}, "scene.json: whitewater.trapped_air_rate: must be >= 0");

  // Caches without velocities: PLY points with x, y, z only.
  const fs::path bare = scratch() / "bare";
  fs::create_directories(bare / "particles");
  ParticleFrame frame = test::latticeFluid({0, 0, 0}, {0.1f, 0.1f, 0.1f}, 0.01f, {0, 0, 0});
  frame.velocity.clear();
  frame.id.clear();
  for (int f = 1; f <= 2; ++f) writeParticlePly(OutputLayout(bare).particlesPly(f), frame);
  expectBad({"whitewater", bare.string()}, "no velocities");
}

TEST(WhitewaterStage, InspectCountsEachKind) {
  const fs::path out = copyOf(towerBake(), "inspect");
  ASSERT_EQ(test::run({"whitewater", out.string(), "--ply"}, scratch() / "inspect_ww.log"), 0);
  const int frame = frameCount(out) - 4;
  const fs::path file = OutputLayout(out).whitewater(frame);
  const WhitewaterFrame read = readWhitewaterVdb(file);
  const auto counts = read.counts();
  ASSERT_GT(counts[0] + counts[1] + counts[2], 0u);
  const fs::path log = scratch() / "inspect.log";
  ASSERT_EQ(test::run({"inspect", file.string()}, log), 0);
  const std::string text = test::readLog(log);
  EXPECT_NE(text.find("kind: whitewater"), std::string::npos) << text;
  EXPECT_NE(text.find("spray: " + std::to_string(counts[0]) + "\n"), std::string::npos) << text;
  EXPECT_NE(text.find("foam: " + std::to_string(counts[1]) + "\n"), std::string::npos) << text;
  EXPECT_NE(text.find("bubble: " + std::to_string(counts[2]) + "\n"), std::string::npos) << text;
  // The PLY twin holds the same particles.
  const ParticleFrame ply = readParticleFrame(OutputLayout(out).whitewaterPly(frame));
  EXPECT_EQ(ply.size(), read.particles.size());
}

TEST(WhitewaterStage, RunDoesItOnceAndRedoesOnlyItWhenItsSettingsChange) {
  const fs::path out = scratch() / "run";
  const std::vector<std::string> base{"run", kScenes + "/tower.json", "--set", "size=seed", "--set", "output.end_time=0.5",
                                      "--no-render", "-o", out.string()};
  ASSERT_EQ(test::run(base, scratch() / "run1.log"), 0) << test::readLog(scratch() / "run1.log");
  const int frames = frameCount(out);
  ASSERT_EQ(frames, 15);
  const std::vector<std::uint64_t> first = checksums(out, frames);
  ASSERT_EQ(test::run(base, scratch() / "run2.log"), 0);
  const std::string second = test::readLog(scratch() / "run2.log");
  EXPECT_NE(second.find("whitewater: inputs unchanged, skipped"), std::string::npos) << second;
  std::vector<std::string> doubled = base;
  doubled.insert(doubled.end(), {"--set", "whitewater.rate_scale=2"});
  ASSERT_EQ(test::run(doubled, scratch() / "run3.log"), 0);
  const std::string third = test::readLog(scratch() / "run3.log");
  EXPECT_NE(third.find("bake: scene unchanged"), std::string::npos) << third;
  EXPECT_EQ(third.find("whitewater: inputs unchanged"), std::string::npos) << third;
  EXPECT_NE(checksums(out, frames), first);
}

TEST(WhitewaterStage, PreviewsDrawWhitewaterWhite) {
  const fs::path out = copyOf(towerBake(), "render");
  ASSERT_EQ(test::run({"whitewater", out.string()}, scratch() / "render_ww.log"), 0);
  const int frame = frameCount(out) - 6;
  const std::string frames = std::to_string(frame) + "-" + std::to_string(frame);
  const auto whitePixels = [&](const std::vector<std::string>& extra) {
    std::vector<std::string> args{"render", out.string(), "--particles", "--frames", frames, "--width", "320",
                                  "--height", "180", "--force"};
    args.insert(args.end(), extra.begin(), extra.end());
    EXPECT_EQ(test::run(args, scratch() / "render.log"), 0) << test::readLog(scratch() / "render.log");
    const render::Image image = render::readPng(OutputLayout(out).render(frame));
    std::size_t white = 0;
    for (int y = 0; y < image.height; ++y)
      for (int x = 0; x < image.width; ++x) {
        const std::uint8_t* p = image.pixel(x, y);
        white += p[0] > 200 && p[1] > 200 && p[2] > 200;
      }
    return white;
  };
  const std::size_t without = whitePixels({"--no-whitewater"}), with = whitePixels({});
  std::printf("near-white pixels: %zu without whitewater, %zu with\n", without, with);
  EXPECT_GT(with, without + 200);
}

TEST(FoamDensity, AUniformCloudReadsItsParticlesPerSpacingCubed) {
  // Foam at half the spacing: 8 particles per spacing^3 in the middle of the cloud.
  const double s = 0.01;
  const ParticleFrame cloud = test::latticeFluid({0, 0, 0}, {0.1f, 0.1f, 0.1f}, Real(s / 2), {0, 0, 0});
  const openvdb::FloatGrid::Ptr grid = surfacing::foamDensityGrid(cloud.position, s, s / 2);
  EXPECT_EQ(grid->getGridClass(), openvdb::GRID_FOG_VOLUME);
  const auto accessor = grid->getConstAccessor();
  const openvdb::Coord middle(10, 10, 10);  // (0.05, 0.05, 0.05)
  EXPECT_NEAR(accessor.getValue(middle), 8.0, 0.4);
  EXPECT_TRUE(accessor.isValueOn(middle));
  EXPECT_EQ(accessor.getValue(openvdb::Coord(40, 10, 10)), 0.0f);  // 0.2 m: beyond the cloud and R
  EXPECT_FALSE(accessor.isValueOn(openvdb::Coord(40, 10, 10)));
}

TEST(WhitewaterStage, SurfaceWritesAFoamGridFromTheWhitewaterFiles) {
  const fs::path out = copyOf(towerBake(), "foam");
  const int frame = frameCount(out) - 5;
  const std::string frames = std::to_string(frame) + "-" + std::to_string(frame);
  const fs::path log = scratch() / "foam.log";
  // Asked for before the whitewater exists: one line naming the missing file.
  EXPECT_EQ(test::run({"surface", out.string(), "--frames", frames, "--foam-density", "--no-mesh"}, log), 2)
      << test::readLog(log);
  EXPECT_NE(test::readLog(log).find("whitewater." + OutputLayout::pad(frame) + ".vdb: no such file"), std::string::npos)
      << test::readLog(log);
  ASSERT_EQ(test::run({"whitewater", out.string()}, log), 0) << test::readLog(log);
  ASSERT_EQ(test::run({"surface", out.string(), "--frames", frames, "--foam-density", "--no-mesh", "--force"}, log), 0)
      << test::readLog(log);
  openvdb::initialize();
  openvdb::io::File file(OutputLayout(out).surface(frame).string());
  file.open();
  const auto foam = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("foam"));
  file.close();
  ASSERT_TRUE(foam);
  // Every foam particle of the frame lies in the grid's active region, where the value is > 0.
  const WhitewaterFrame diffuse = readWhitewaterVdb(OutputLayout(out).whitewater(frame));
  ASSERT_GT(diffuse.counts()[1], 0u);
  const auto accessor = foam->getConstAccessor();
  for (std::size_t i = 0; i < diffuse.particles.size(); ++i) {
    if (diffuse.type[i] != DiffuseType::Foam) continue;
    const Vec3r& x = diffuse.particles.position[i];
    const openvdb::Coord ijk = foam->transform().worldToIndexCellCentered(openvdb::Vec3d(x.x(), x.y(), x.z()));
    EXPECT_GT(accessor.getValue(ijk), 0.0f);
  }
}
