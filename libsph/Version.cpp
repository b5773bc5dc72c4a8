#include "libsph/Version.h"

#include "CascadeRevision.h"  // generated at build time: CASCADE_GIT_REVISION

namespace cascade {

std::string cascadeVersion() {
  const std::string revision = CASCADE_GIT_REVISION;
  return std::string(CASCADE_VERSION) + (revision.empty() ? "" : " (git " + revision + ")");
}

std::string writtenBy() { return "written by cascade " + cascadeVersion(); }

} // namespace cascade
