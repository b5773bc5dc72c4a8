/// @file BakeCheckpoint.h
/// @brief The state a bake needs to continue after it was stopped (SIGINT,
///        SIGTERM or SIGKILL): OUT/.checkpoint/bake.ckpt, written atomically
///        after every complete frame. It holds the input hash of the scene it
///        belongs to, the last complete frame, the emitter and kill counters,
///        the probe rows so far, and the solver's whole binary state
///        (Simulation::save). A resumed bake restores it into a simulation
///        set up from the same scene and continues bit-identically.
#pragma once

#include "libsph/scene/FluidSources.h"

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace cascade {
class Simulation;
}

namespace cascade::scene {

struct BakeCheckpoint {
  std::string inputHash;
  int frame = 0;                         ///< last complete frame (0: none)
  std::vector<EmitterState> emitters;
  std::uint64_t killed = 0;              ///< particles removed by kill regions
  std::int64_t probeSamples = 0;         ///< probe samples taken so far
  std::string probeRows;                 ///< probes.csv body so far (no header)
  double wallSeconds = 0;                ///< bake wall time spent so far
};

std::filesystem::path checkpointPath(const std::filesystem::path& outDir);

/// Writes the checkpoint and the simulation state atomically.
void writeCheckpoint(const std::filesystem::path& path, const BakeCheckpoint& checkpoint,
                     const Simulation& simulation);

/// Reads the header of a checkpoint (not the simulation state); nullopt if
/// the file is missing or not a checkpoint.
std::optional<BakeCheckpoint> readCheckpointHeader(const std::filesystem::path& path);

/// Reads a checkpoint and restores the simulation state into `simulation`.
/// Throws InputError naming the file if it is damaged.
BakeCheckpoint readCheckpoint(const std::filesystem::path& path, Simulation& simulation);

} // namespace cascade::scene
