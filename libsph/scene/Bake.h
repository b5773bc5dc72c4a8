/// @file Bake.h
/// @brief `cascade bake`: runs a scene's simulation and writes, under OUT
///        (docs/cli.md), one particle cache per output frame
///        (particles/particles.NNNN.vdb), scene.json (every default filled
///        in), probes.csv, geometry/solids.obj (the solids in world
///        coordinates, one group per solid, for the renderer) and the bake
///        record of manifest.json. Every file is written whole or not at all.
///
/// Resumable: after each frame the whole state is checkpointed atomically
/// (BakeCheckpoint.h). Run again with the same scene, a bake continues from
/// the last complete frame and ends with the same particles, bit for bit, as
/// one never stopped: steps land exactly on frame and probe times, emitters
/// release layers at fixed times, and the solver state is restored exactly.
#pragma once

#include "libsph/io/OutputLayout.h"
#include "libsph/scene/Scene.h"

#include <csignal>
#include <cstdint>
#include <filesystem>
#include <ostream>
#include <string>

namespace cascade {
class DomainPartition;
}

namespace cascade::scene {

struct BakeOptions {
  std::filesystem::path outDir;
  FrameRange frames;                 ///< frames to write (the bake simulates from the start)
  bool resume = true;                ///< continue from a matching checkpoint
  std::ostream* log = nullptr;       ///< messages and progress (null: silent)
  int progressTerminal = -1;         ///< -1 detect, 0 plain lines, 1 in-place line
  /// Bake even when the memory estimate (estimateBakeMemory) exceeds what the machine has.
  bool ignoreMemory = false;
  /// Set asynchronously (SIGINT/SIGTERM handler) to stop after the current step.
  const volatile std::sig_atomic_t* stopFlag = nullptr;
  /// Over MPI ranks (DomainPartition.h): every rank calls bakeScene with its own
  /// partition; the fluid is split between them and rank 0 writes every file (frames
  /// and checkpoints hold all ranks' particles, in id order). Null: one process.
  DomainPartition* partition = nullptr;
};

struct BakeResult {
  int frameCount = 0;                ///< frames of the scene
  int firstFrame = 1, lastFrame = 0; ///< range written
  int framesWritten = 0;             ///< in this run
  int resumedAfter = 0;              ///< checkpoint frame continued from (0: fresh)
  bool upToDate = false;             ///< nothing to do: every requested frame existed
  bool interrupted = false;          ///< stopped by stopFlag after `lastFrame`
  bool complete = false;             ///< frames 1..frameCount all baked
  double simulatedTime = 0;          ///< s
  double wallSeconds = 0;            ///< this run
  std::uint64_t steps = 0;           ///< this run
  std::size_t particles = 0;         ///< at the end
  std::uint64_t removed = 0;         ///< left the domain or entered a kill region, since the start
  std::string inputHash;
};

/// Bakes `scene` into options.outDir. Throws InputError (bad scene or
/// assets), InstabilityError (frames before it stay on disk).
BakeResult bakeScene(const Scene& scene, const BakeOptions& options);

/// The probes.csv header: t,<name>[_x,_y,_z]... (force probes take three columns).
std::string probeHeader(const Scene& scene);

} // namespace cascade::scene
