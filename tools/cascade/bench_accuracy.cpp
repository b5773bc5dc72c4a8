#include "Benchmarks.h"

#include "libsph/Errors.h"

namespace cascade::cli {

BenchTable benchAccuracy() {
  throw NotImplementedError("bench accuracy: not implemented yet (issue #7)");
}

} // namespace cascade::cli
