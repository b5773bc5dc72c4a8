// `cascade run SCENE.json [-o OUT] [--set KEY=VALUE]...` (docs/cli.md):
// bake, whitewater (when the scene has a "whitewater" block), surface, render;
// a stage whose inputs did not change is skipped.
//
// Input hashes (kept in OUT/manifest.json, Manifest.h): the bake's covers the
// resolved scene but its surface and whitewater blocks, camera and lights, and
// its mesh files; the whitewater and surface stages' each chain the bake's with
// their block, the render stage's chains the surface stage's with the
// whitewater stage's, the camera and lights. So a new camera re-renders, new
// surface or whitewater settings redo that stage (and the render), and none
// re-bakes. The later stages run as `cascade whitewater|surface|render OUT`
// child processes (stages talk through files only);
// when a stage's input changed, its old outputs are removed first so that no
// stale frame survives.
#include "Commands.h"
#include "SceneCommand.h"

#include "libsph/Errors.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/io/OutputLayout.h"
#include "libsph/scene/Manifest.h"
#include "libsph/scene/SceneJson.h"

#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

namespace cascade::cli {

namespace fs = std::filesystem;

namespace {

/// Runs this program with `arguments`; returns its exit status (128 + signal if killed).
int runSelf(const std::vector<std::string>& arguments) {
  std::vector<char*> argv;
  std::string self = "/proc/self/exe";
  std::string name = "cascade";
  argv.push_back(name.data());
  std::vector<std::string> copy = arguments;
  for (std::string& argument : copy) argv.push_back(argument.data());
  argv.push_back(nullptr);
  std::cout.flush();
  std::cerr.flush();
  const pid_t child = ::fork();
  if (child < 0) throw std::runtime_error("run: cannot start a stage (fork failed)");
  if (child == 0) {
    ::execv(self.c_str(), argv.data());
    std::_Exit(127);
  }
  int status = 0;
  while (::waitpid(child, &status, 0) < 0) {
    if (errno != EINTR) throw std::runtime_error("run: lost a stage process");
  }
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return 1;
}

bool allFramesExist(const fs::path& dir, const std::string& prefix, const std::string& extension, int count) {
  const std::vector<int> frames = listFrames(dir, prefix, extension);
  int found = 0;
  for (int f : frames) found += (f >= 1 && f <= count);
  return found == count;
}

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// One kind of file a stage writes per frame: DIR/PREFIX.NNNN.EXT.
struct FrameFiles {
  fs::path dir;
  std::string prefix, extension;
};

/// Runs `cascade STAGE OUT` unless the manifest says it is current and all of
/// `outputs` exist for every frame; before running, removes `stale` (the outputs
/// of every form the stage may have written before). Records the run.
void runStage(const std::string& stage, const fs::path& outDir, const std::string& sceneName,
              const std::string& inputHash, int frameCount, const std::vector<FrameFiles>& outputs,
              const std::vector<FrameFiles>& stale) {
  const OutputLayout layout(outDir);
  const nlohmann::json manifest = scene::readManifest(layout.manifest());
  bool complete = true;
  for (const FrameFiles& files : outputs)
    complete = complete && allFramesExist(files.dir, files.prefix, files.extension, frameCount);
  if (scene::stageIsCurrent(manifest, stage, inputHash) && complete) {
    std::cerr << "run: " << stage << ": inputs unchanged, skipped\n";
    return;
  }
  for (const FrameFiles& files : stale) removeFrameFiles(files.dir, files.prefix, files.extension);
  std::cerr << "run: " << stage << "...\n";
  const auto start = std::chrono::steady_clock::now();
  const int status = runSelf({stage, outDir.string()});
  const FrameFiles& counted = outputs.front();
  nlohmann::json record{{"done", status == 0}, {"input_hash", inputHash}, {"seconds", secondsSince(start)},
                        {"frames", listFrames(counted.dir, counted.prefix, counted.extension).size()}};
  if (status != 0) record["exit_status"] = status;
  scene::recordStage(layout.manifest(), sceneName, stage, record);
  if (status == kExitBadInput) throw InputError("run: " + stage + " stage failed on bad input (see above)");
  if (status == kExitUnstable) throw InstabilityError("run: " + stage + " stage: unstable (see above)");
  if (status != 0) throw std::runtime_error(stage + " stage failed with exit status " + std::to_string(status));
}

} // namespace

void addRunCommand(CLI::App& app) {
  CLI::App* command = app.add_subcommand("run", "Bake, whitewater (if the scene has it), surface and render a scene, skipping stages whose inputs did not change");
  struct Args {
    std::string scene, out;
    std::vector<std::string> sets;
    bool noRender = false, noSurface = false, noWhitewater = false, ignoreMemory = false;
  };
  auto args = std::make_shared<Args>();
  command->add_option("scene", args->scene, "Scene file (JSON)")->required();
  command->add_option("-o,--out", args->out, "Output folder (default out/<scene name>)");
  command->add_option("--set", args->sets, "Override a scene value: KEY=VALUE (dotted path)")->take_all();
  command->add_flag("--no-surface", args->noSurface, "Stop after the bake");
  command->add_flag("--no-whitewater", args->noWhitewater, "Skip the whitewater stage of a scene that has one");
  command->add_flag("--no-render", args->noRender, "Stop after surfacing");
  command->add_flag("--ignore-memory", args->ignoreMemory,
                    "Bake even if the memory estimate exceeds what this machine has available");
  command->callback([args] {
    const auto start = std::chrono::steady_clock::now();
    const scene::Scene scene = scene::loadScene(args->scene, args->sets);
    const fs::path outDir = defaultOutDir(scene, args->out);
    const OutputLayout layout(outDir);
    const int frameCount = scene.output.frameCount();
    const std::vector<std::string> meshHashes = scene::meshContentHashes(scene);  // the mesh files, read once
    const scene::StageHashes hashes = scene::stageInputHashes(scene, meshHashes, !args->noWhitewater);
    const std::string& bakeHash = hashes.bake;

    const nlohmann::json manifest = scene::readManifest(layout.manifest());
    const bool bakeCurrent = scene::stageIsCurrent(manifest, "bake", bakeHash) &&
                             allFramesExist(layout.particlesDir(), "particles", "vdb", frameCount);
    if (bakeCurrent) {
      std::cerr << "run: bake: scene unchanged (input hash " << bakeHash << "), skipped\n";
    } else {
      std::cerr << "run: bake " << scene.name << " -> " << outDir.string() << "\n";
      runBake(scene, outDir, "", false, args->ignoreMemory);
    }
    if (!args->noSurface) {
      // The later stages read OUT/scene.json, with this scene's surface and whitewater
      // settings, camera and lights: the bake wrote it, unless it was skipped.
      if (bakeCurrent) scene::writeResolvedScene(scene, layout.scene(), meshHashes);
      const std::string& whitewaterHash = hashes.whitewater;
      if (!whitewaterHash.empty()) {
        std::vector<FrameFiles> outputs{{layout.whitewaterDir(), "whitewater", "vdb"}};
        if (scene.whitewater->ply) outputs.push_back({layout.whitewaterDir(), "whitewater", "ply"});
        runStage("whitewater", outDir, scene.name, whitewaterHash, frameCount, outputs,
                 {{layout.whitewaterDir(), "whitewater", "vdb"}, {layout.whitewaterDir(), "whitewater", "ply"}});
      }
      const std::string& surfaceHash = hashes.surface;
      const scene::SurfaceSettings& surface = scene.surface;
      std::vector<FrameFiles> surfaceOutputs;
      if (surface.outputs != "vdb") surfaceOutputs.push_back({layout.meshDir(), "fluid", surface.meshFormat});
      if (surface.outputs != "mesh") surfaceOutputs.push_back({layout.surfaceDir(), "surface", "vdb"});
      runStage("surface", outDir, scene.name, surfaceHash, frameCount, surfaceOutputs,
               {{layout.meshDir(), "fluid", "obj"}, {layout.meshDir(), "fluid", "ply"},
                {layout.surfaceDir(), "surface", "vdb"}});
      if (!args->noRender && surface.outputs == "vdb") {
        std::cerr << "run: render: skipped (surface.outputs is \"vdb\": no mesh to draw; "
                     "`cascade render OUT --particles` draws the particles)\n";
      } else if (!args->noRender) {
        const FrameFiles frames{layout.renderDir(), "frame", "png"};
        runStage("render", outDir, scene.name, hashes.render, frameCount,
                 {frames}, {frames});
      }
    }
    std::fprintf(stderr, "run: %s done in %.1f s -> %s\n", scene.name.c_str(), secondsSince(start),
                 outDir.string().c_str());
  });
}

} // namespace cascade::cli
