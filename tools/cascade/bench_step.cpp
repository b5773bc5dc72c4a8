#include "Benchmarks.h"

#include "libsph/Errors.h"

namespace cascade::cli {

BenchTable benchStep() {
  throw NotImplementedError("bench step: not implemented yet (issue #3)");
}

} // namespace cascade::cli
