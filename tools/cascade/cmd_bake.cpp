// `cascade bake SCENE.json [-o OUT] [--frames A-B] [--set KEY=VALUE]...` (docs/cli.md).
#include "Commands.h"
#include "SceneCommand.h"

#include "distributed/MpiRuntime.h"
#include "libsph/Errors.h"
#include "libsph/scene/Bake.h"
#include "libsph/scene/SceneJson.h"

#include <csignal>
#include <iostream>
#include <memory>

namespace cascade::cli {

namespace {
volatile std::sig_atomic_t gStopRequested = 0;
extern "C" void requestStop(int) { gStopRequested = 1; }
} // namespace

void installStopHandlers() {
  std::signal(SIGINT, requestStop);
  std::signal(SIGTERM, requestStop);
}

const volatile std::sig_atomic_t* stopFlag() { return &gStopRequested; }

std::filesystem::path defaultOutDir(const scene::Scene& scene, const std::string& given) {
  return given.empty() ? std::filesystem::path("out") / scene.name : std::filesystem::path(given);
}

scene::BakeResult runBake(const scene::Scene& scene, const std::filesystem::path& outDir,
                          const std::string& framesText, bool restart, bool ignoreMemory, const std::string& rankCuts) {
  scene::BakeOptions options;
  options.outDir = outDir;
  options.ignoreMemory = ignoreMemory;
  if (!framesText.empty()) options.frames = parseFrameRange(framesText);
  options.resume = !restart;
  // Under mpirun: every rank bakes its share of the fluid; rank 0 logs and writes.
  const distributed::MpiSession* session = distributed::currentSession();
  const bool firstRank = session == nullptr || session->rank() == 0;
  options.log = firstRank ? &std::cerr : nullptr;
  const std::unique_ptr<DomainPartition> partition = distributed::makeWorldPartition(&std::cerr, rankCuts);
  if (!rankCuts.empty() && !partition) throw InputError("--rank-cuts: only under mpirun");
  options.partition = partition.get();
  options.stopFlag = stopFlag();
  installStopHandlers();
  scene::BakeResult result = scene::bakeScene(scene, options);
  if (partition && firstRank) std::cerr << distributed::partitionSummary(*partition) << '\n';
  if (result.interrupted)
    throw std::runtime_error("bake interrupted after frame " + std::to_string(result.lastFrame) +
                             "; run the same command again to continue");
  return result;
}

void addBakeCommand(CLI::App& app) {
  CLI::App* command = app.add_subcommand("bake", "Simulate a scene into OUT/particles (resumable)");
  struct Args {
    std::string scene, out, frames, rankCuts;
    std::vector<std::string> sets;
    bool restart = false, ignoreMemory = false;
  };
  auto args = std::make_shared<Args>();
  command->add_option("scene", args->scene, "Scene file (JSON)")->required();
  command->add_option("-o,--out", args->out, "Output folder (default out/<scene name>)");
  command->add_option("--frames", args->frames, "Frames A-B to write (1-based, inclusive)");
  command->add_option("--set", args->sets, "Override a scene value: KEY=VALUE (dotted path)")->take_all();
  command->add_flag("--restart", args->restart, "Ignore a checkpoint and bake from the start");
  command->add_flag("--ignore-memory", args->ignoreMemory,
                    "Bake even if the memory estimate exceeds what this machine has available");
  command->add_option("--rank-cuts", args->rankCuts,
                      "Under mpirun: slab cuts AXIS=C1,C2,... in metres, kept for the whole bake (default: equal shares, rebalanced)");
  command->callback([args] {
    const scene::Scene scene = scene::loadScene(args->scene, args->sets);
    runBake(scene, defaultOutDir(scene, args->out), args->frames, args->restart, args->ignoreMemory, args->rankCuts);
  });
}

} // namespace cascade::cli
