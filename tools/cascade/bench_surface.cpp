#include "Benchmarks.h"

#include "libsph/Errors.h"

namespace cascade::cli {

BenchTable benchSurface() {
  throw NotImplementedError("bench surface: not implemented yet (issue #5)");
}

} // namespace cascade::cli
