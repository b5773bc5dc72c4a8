/// @file Benchmarks.h
/// @brief `cascade bench KIND`: each benchmark builds its table in its own file.
#pragma once

#include "BenchTable.h"

#include "libsph/solver/Simulation.h"

#include <filesystem>
#include <string>
#include <vector>

namespace cascade::cli {

/// The output paths of the running `cascade bench` (for benchmarks that also
/// write files, e.g. bench accuracy's plot next to the JSON).
struct BenchPaths {
  std::string json;  ///< --json FILE (empty: none)
  std::string plot;  ///< --plot FILE (empty: next to the JSON)
};
BenchPaths& benchPaths();

BenchTable benchNeighbors();  ///< bench_neighbors.cpp
BenchTable benchStep();       ///< bench_step.cpp
/// bench_step.cpp: `steps` steps of the bake in `out`, continued from its checkpoint.
BenchTable benchStepFrom(const std::filesystem::path& out, int steps);
/// bench step's dam break (bench_step.cpp): the settings, and a column of about `target`
/// particles against the back wall of a tank four columns long.
SimulationSettings benchDamBreakSettings();
void addBenchDamBreak(Simulation& simulation, std::size_t target);
/// bench_step_ranks.cpp: threads against MPI ranks (N in `ranks`) at about `target` particles.
BenchTable benchStepRanks(const std::vector<int>& ranks, long target);
/// bench_step_ranks.cpp: one MPI run of benchStepRanks (under mpirun; rank 0 prints one line).
void benchStepMpiChild(long target);
BenchTable benchAccuracy();   ///< bench_accuracy.cpp
BenchTable benchSurface();    ///< bench_surface.cpp
BenchTable benchRender();     ///< bench_render.cpp
BenchTable benchBodies();     ///< bench_bodies.cpp
BenchTable benchWhitewater(); ///< bench_whitewater.cpp

} // namespace cascade::cli
