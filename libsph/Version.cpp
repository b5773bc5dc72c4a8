#include "libsph/Version.h"

namespace cascade {

std::string cascadeVersion() {
  const std::string revision = CASCADE_GIT_REVISION;
  return std::string(CASCADE_VERSION) + (revision.empty() ? "" : " (git " + revision + ")");
}

std::string writtenBy() { return "written by cascade " + cascadeVersion(); }

} // namespace cascade
