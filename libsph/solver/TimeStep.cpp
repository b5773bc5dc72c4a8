#include "libsph/solver/TimeStep.h"

#include "libsph/solver/TimeStepDFSPH.h"
#include "libsph/solver/TimeStepWCSPH.h"

#include <stdexcept>

namespace cascade {

std::unique_ptr<TimeStep> makeTimeStep(const std::string& type) {
  if (type == "wcsph") return std::make_unique<TimeStepWCSPH>();
  if (type == "dfsph") return std::make_unique<TimeStepDFSPH>();
  throw std::invalid_argument("unknown solver type '" + type + "'");
}

std::vector<std::string> timeStepTypes() { return {"wcsph", "dfsph"}; }

} // namespace cascade
