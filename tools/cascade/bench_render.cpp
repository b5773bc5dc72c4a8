#include "Benchmarks.h"

#include "libsph/Errors.h"

namespace cascade::cli {

BenchTable benchRender() {
  throw NotImplementedError("bench render: not implemented yet (issue #6)");
}

} // namespace cascade::cli
