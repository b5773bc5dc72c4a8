/// @file Benchmarks.h
/// @brief `cascade bench KIND`: each benchmark builds its table in its own file.
#pragma once

#include "BenchTable.h"

namespace cascade::cli {

BenchTable benchNeighbors();  ///< bench_neighbors.cpp (issue 2)
BenchTable benchStep();       ///< bench_step.cpp (issue 3)
BenchTable benchAccuracy();   ///< bench_accuracy.cpp (issue 7)
BenchTable benchSurface();    ///< bench_surface.cpp (issue 5)
BenchTable benchRender();     ///< bench_render.cpp (issue 6)

} // namespace cascade::cli
