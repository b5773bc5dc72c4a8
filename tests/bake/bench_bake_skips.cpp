// What each "skip what a scene does not need" saves.
// Not a test: prints a table. Usage: bench_bake_skips [end_time_s] [size]
// Base: the dam break scene (scenes/dambreak.json) with viscosity, a mesh
// obstacle (the tower, at the far end of the tank, which the water does not
// reach in the time baked) and four probes at 500 Hz; each row removes one of
// them, as a scene that does not need it would, and reports the CPU time of
// the bake (all threads; wall time on a shared machine mostly measures the others). The last rows time `cascade run`'s decision for an unchanged
// scene (load, hash, manifest check) against re-baking it.
#include "libsph/io/OutputLayout.h"
#include "libsph/scene/Bake.h"
#include "libsph/scene/Manifest.h"
#include "libsph/scene/SceneJson.h"

#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

using namespace cascade;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {
double seconds(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

/// CPU seconds of this process (all threads): unlike wall time, not inflated
/// by other work on a shared machine.
double cpuSeconds() {
  rusage usage{};
  ::getrusage(RUSAGE_SELF, &usage);
  return double(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         1e-6 * double(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

struct Row {
  std::string name;
  double wall = 0, cpu = 0;
  std::uint64_t steps = 0;
};

Row bake(const std::string& name, const fs::path& sceneFile, std::vector<std::string> sets, const fs::path& out) {
  fs::remove_all(out);
  const scene::Scene scene = scene::loadScene(sceneFile, sets);
  scene::BakeOptions options;
  options.outDir = out;
  const auto start = Clock::now();
  const double cpuStart = cpuSeconds();
  const scene::BakeResult result = scene::bakeScene(scene, options);
  return {name, seconds(start), cpuSeconds() - cpuStart, result.steps};
}
} // namespace

int main(int argc, char** argv) {
  const std::string endTime = argc > 1 ? argv[1] : "0.1";
  const std::string size = argc > 2 ? argv[2] : "production";
  const fs::path sceneFile = fs::path(CASCADE_SOURCE_DIR) / "scenes" / "dambreak.json";
  const std::string tower = (fs::path(CASCADE_SOURCE_DIR) / "scenes" / "assets" / "tower.obj").string();
  const fs::path out = fs::temp_directory_path() / "cascade_bench_skips";
  const std::vector<std::string> base{
      "size=" + size, "output.end_time=" + endTime, "output.fps=50",
      "fluid.viscosity=0.001",
      R"(boundaries.obstacles=[{"name":"tower","mesh":")" + tower +
          R"(","translate":[0.5,0.01,0],"scale":0.12}])",
      R"(probes=[{"name":"X","type":"front","direction":[1,0,0]},{"name":"H","type":"height","at":[0.1,0.01]},
                 {"name":"P","type":"pressure","at":[0,0.01,0.01]},{"name":"F","type":"force","obstacle":"tower"}])",
      "output.probe_rate=500"};
  auto without = [&](const std::string& prefix, const std::string& replacement) {
    std::vector<std::string> sets;
    for (const std::string& s : base)
      if (s.rfind(prefix, 0) != 0) sets.push_back(s);
    if (!replacement.empty()) sets.push_back(replacement);
    return sets;
  };

  std::vector<Row> rows;
  rows.push_back(bake("everything (viscosity, obstacle, 4 probes)", sceneFile, base, out));
  rows.push_back(bake("no viscosity pass (viscosity 0)", sceneFile, without("fluid.viscosity", "fluid.viscosity=0"), out));
  {
    // Without the obstacle the force probe must go too.
    std::vector<std::string> sets = without("boundaries.obstacles", "");
    for (auto& s : sets)
      if (s.rfind("probes=", 0) == 0)
        s = R"(probes=[{"name":"X","type":"front","direction":[1,0,0]},{"name":"H","type":"height","at":[0.1,0.01]},
                      {"name":"P","type":"pressure","at":[0,0.01,0.01]}])";
    rows.push_back(bake("no obstacle boundary set (3 probes)", sceneFile, sets, out));
  }
  rows.push_back(bake("no probe work (no probes)", sceneFile, without("probes", "probes=[]"), out));

  // cascade run on an unchanged scene: load + hash + manifest check, no bake.
  fs::remove_all(out);
  const scene::Scene scene = scene::loadScene(sceneFile, base);
  scene::BakeOptions options;
  options.outDir = out;
  double cpuStart = cpuSeconds();
  scene::bakeScene(scene, options);
  const double fullBake = cpuSeconds() - cpuStart;
  auto start = Clock::now();
  const scene::Scene again = scene::loadScene(sceneFile, base);
  const bool current = scene::stageIsCurrent(scene::readManifest(OutputLayout(out).manifest()), "bake",
                                             scene::sceneInputHash(again));
  const double check = seconds(start);

  std::printf("bench_bake_skips: dambreak size=%s, end_time=%s s\n", size.c_str(), endTime.c_str());
  std::printf("%-46s %8s %8s %8s %10s\n", "variant", "cpu_s", "wall_s", "steps", "cpu_saved");
  for (const Row& row : rows)
    std::printf("%-46s %8.3f %8.3f %8llu %9.1f%%\n", row.name.c_str(), row.cpu, row.wall,
                static_cast<unsigned long long>(row.steps), 100.0 * (rows[0].cpu - row.cpu) / rows[0].cpu);
  std::printf("%-46s %8.3f %8s %8s %10s\n", "run: re-bake unchanged scene", fullBake, "", "", "");
  std::printf("%-46s %8.4f %8s %8s %9.1f%%  (%s)\n", "run: skip unchanged bake (hash check, wall)", check, "", "",
              100.0 * (fullBake - check) / fullBake, current ? "skipped" : "NOT CURRENT");
  fs::remove_all(out);
  return 0;
}
