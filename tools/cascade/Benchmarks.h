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

BenchTable benchNeighbors();  ///< bench_neighbors.cpp (issue 2)
BenchTable benchStep();       ///< bench_step.cpp (issue 3)
BenchTable benchAccuracy();   ///< bench_accuracy.cpp (issue 7)
BenchTable benchSurface();    ///< bench_surface.cpp (issue 5)
BenchTable benchRender();     ///< bench_render.cpp (issue 6)
BenchTable benchBodies();     ///< bench_bodies.cpp (issue 16)

} // namespace cascade::cli
