/// @file Benchmarks.h
/// @brief `cascade bench KIND`: each benchmark builds its table in its own file.
#pragma once

#include "BenchTable.h"

#include <string>

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
BenchTable benchAccuracy();   ///< bench_accuracy.cpp
BenchTable benchSurface();    ///< bench_surface.cpp
BenchTable benchRender();     ///< bench_render.cpp
BenchTable benchBodies();     ///< bench_bodies.cpp
BenchTable benchWhitewater(); ///< bench_whitewater.cpp

} // namespace cascade::cli
