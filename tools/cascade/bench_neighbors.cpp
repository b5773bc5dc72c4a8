#include "Benchmarks.h"

#include "libsph/Errors.h"

namespace cascade::cli {

BenchTable benchNeighbors() {
  throw NotImplementedError("bench neighbors: not implemented yet (issue #2)");
}

} // namespace cascade::cli
