/// @file SceneCommand.h
/// @brief Shared by `cascade bake` and `cascade run`: the default output
///        folder, the SIGINT/SIGTERM stop flag and one bake with its options.
#pragma once

#include "libsph/scene/Bake.h"
#include "libsph/scene/Scene.h"

#include <csignal>
#include <filesystem>
#include <string>

namespace cascade::cli {

/// OUT: as given, else out/<scene name> (docs/cli.md).
std::filesystem::path defaultOutDir(const scene::Scene& scene, const std::string& given);

/// Installs SIGINT/SIGTERM handlers that ask a bake to stop after its current step.
void installStopHandlers();
const volatile std::sig_atomic_t* stopFlag();

/// Bakes with progress on stderr; throws if interrupted (exit 1, checkpoint kept).
/// `ignoreMemory`: bake even when the memory estimate exceeds what the machine has.
scene::BakeResult runBake(const scene::Scene& scene, const std::filesystem::path& outDir,
                          const std::string& framesText, bool restart, bool ignoreMemory = false,
                          const std::string& rankCuts = "");

} // namespace cascade::cli
