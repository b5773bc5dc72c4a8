// libFuzzer harness: the particle cache readers (ParticleCache.h), as an OpenVDB
// points file and as a PLY point file. A bad file must end in InputError; a file
// that reads must give attributes of one length each (or none).
#include "FuzzInput.h"

#include "libsph/Errors.h"
#include "libsph/io/ParticleCache.h"

#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace cascade;
  for (const char* extension : {".vdb", ".ply"}) {
    try {
      const ParticleFrame frame = readParticleFrame(fuzz::asFile(data, size, extension));
      const std::size_t n = frame.position.size();
      for (std::size_t length : {frame.velocity.size(), frame.id.size(), frame.density.size(), frame.pressure.size()})
        if (length != 0 && length != n) std::abort();
    } catch (const InputError&) {
    }
  }
  return 0;
}
