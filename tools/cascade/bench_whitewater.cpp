// `cascade bench whitewater`: the whitewater stage's time per frame and its
// diffuse particle counts on
//  - the production tower scene (206 k fluid particles, 36 frames; baked first
//    into a cache folder kept between runs, or CASCADE_BENCH_WHITEWATER_TOWER=OUT
//    to use a bake you have), and
//  - the shared splash (BenchSplash.h) at 5.75 mm spacing, 1.0 M fluid
//    particles, moving ballistically over six frames at 30 fps: the cost at a
//    million fluid particles.
// Both with the default settings. Memory: the state is 32 bytes per diffuse
// particle (DiffuseParticles); the table also gives the process's peak resident
// memory.
#include "BenchSplash.h"
#include "Benchmarks.h"

#include "libsph/io/OutputLayout.h"
#include "libsph/io/ParticleCache.h"
#include "libsph/scene/Bake.h"
#include "libsph/scene/SceneJson.h"
#include "whitewater/WhitewaterStage.h"

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>

namespace cascade::cli {

namespace {

namespace fs = std::filesystem;

double peakResidentMb() {
  rusage usage{};
  ::getrusage(RUSAGE_SELF, &usage);
  return double(usage.ru_maxrss) / 1024.0;
}

/// The splash's spacing here: a million fluid particles.
constexpr double kMillionSpacing = 0.00575;

/// The splash as six cache frames 1/30 s apart: the pool keeps its motion, the
/// rest flies ballistically.
void writeSplashFrames(const fs::path& out) {
  const Splash splash = splashParticles(kMillionSpacing);
  ParticleFrame frame;
  frame.position = splash.points;
  frame.velocity = splash.velocities;
  frame.spacing = Real(kMillionSpacing);
  frame.id.resize(frame.size());
  for (std::size_t i = 0; i < frame.size(); ++i) frame.id[i] = ParticleId(i);
  const OutputLayout layout(out);
  fs::create_directories(layout.particlesDir());
  const double dt = 1.0 / 30;
  const Vec3r g(0, 0, Real(-9.81));
  for (int k = 1; k <= 6; ++k) {
    frame.time = k * dt;
    writeParticleFrame(layout.particles(k), frame);
    for (std::size_t i = 0; i < frame.size(); ++i) {
      const bool pool = frame.velocity[i].z() == 0;
      const Vec3r a = pool ? Vec3r::Zero() : g;
      frame.position[i] += Real(dt) * frame.velocity[i] + Real(0.5 * dt * dt) * a;
      frame.velocity[i] += Real(dt) * a;
    }
  }
}

/// Bakes the production tower into `out` (resuming a bake left there).
void bakeTower(const fs::path& out) {
  const scene::Scene scene = scene::loadScene(std::string(CASCADE_SOURCE_DIR) + "/scenes/tower.json");
  scene::BakeOptions options;
  options.outDir = out;
  options.log = &std::cerr;
  options.progressTerminal = 0;
  scene::bakeScene(scene, options);
}

} // namespace

BenchTable benchWhitewater() {
  whitewater::keepFreedMemory();  // as `cascade whitewater` does
  BenchTable table("whitewater",
                   {"case", "fluid_particles", "frames", "substeps", "ms_per_frame", "max_ms", "potentials_ms",
                    "born_per_frame", "diffuse_max", "spray", "foam", "bubbles", "state_bytes_per_diffuse",
                    "peak_rss_mb"});
  const fs::path base = fs::temp_directory_path() / "cascade_bench_whitewater";
  struct Case {
    std::string name;
    fs::path out;
    whitewater::WhitewaterStageOptions options;
  };
  std::vector<Case> cases;
  {
    Case tower{"tower", base / "tower", {}};
    if (const char* given = std::getenv("CASCADE_BENCH_WHITEWATER_TOWER")) tower.out = given;
    else {
      std::cerr << "bench whitewater: baking the production tower into " << tower.out
                << " (kept for later runs; about 10 min on 2 cores)\n";
      bakeTower(tower.out);
    }
    const scene::Scene scene = scene::readResolvedScene(OutputLayout(tower.out).scene());
    tower.options.gravity = Vec3r(Real(scene.gravity[0]), Real(scene.gravity[1]), Real(scene.gravity[2]));
    if (scene.boundaries.domain) {
      const auto& d = *scene.boundaries.domain;
      tower.options.domain = whitewater::RemovalBox{Vec3r(Real(d.min[0]), Real(d.min[1]), Real(d.min[2])),
                                                    Vec3r(Real(d.max[0]), Real(d.max[1]), Real(d.max[2]))};
    }
    cases.push_back(tower);
  }
  {
    Case splash{"splash", base / ("splash_" + std::to_string(::getpid())), {}};
    std::cerr << "bench whitewater: writing the 1 M-particle splash frames into " << splash.out << '\n';
    writeSplashFrames(splash.out);
    cases.push_back(splash);
  }
  for (Case& c : cases) {
    c.options.force = true;
    std::cerr << "bench whitewater: " << c.name << '\n';
    const whitewater::WhitewaterRunReport report = whitewater::runWhitewater(
        OutputLayout(c.out), c.options, {}, [](const std::string& line) { std::cerr << line << '\n'; });
    double seconds = 0, slowest = 0, potentials = 0, substeps = 0;
    std::size_t born = 0, diffuseMax = 0, fluid = 0, timed = 0;
    for (const auto& frame : report.frames) {
      fluid = std::max(fluid, frame.fluid);
      diffuseMax = std::max(diffuseMax, frame.counts[0] + frame.counts[1] + frame.counts[2]);
      if (frame.stats.substeps == 0) continue;  // the first frame: nothing to advance
      ++timed;
      seconds += frame.seconds;
      slowest = std::max(slowest, frame.seconds);
      potentials += frame.potentialSeconds;
      substeps += frame.stats.substeps;
      born += frame.stats.born;
    }
    const auto& last = report.frames.back().counts;
    const double n = double(std::max<std::size_t>(timed, 1));
    table.addRow({c.name, (long long)fluid, (long long)report.frames.size(), substeps / n, 1000 * seconds / n,
                  1000 * slowest, 1000 * potentials / n, (long long)std::llround(double(born) / n), (long long)diffuseMax,
                  (long long)last[0], (long long)last[1], (long long)last[2],
                  (long long)whitewater::DiffuseParticles::bytesPerParticle(), peakResidentMb()});
    if (c.name == "splash") fs::remove_all(c.out);
  }
  return table;
}

} // namespace cascade::cli
