// libFuzzer harness: the whitewater file reader (whitewater/WhitewaterFile.h). A bad
// file must end in InputError; a file that reads must give one type per particle.
#include "FuzzInput.h"

#include "libsph/Errors.h"
#include "whitewater/WhitewaterFile.h"

#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace cascade;
  try {
    const whitewater::WhitewaterFrame frame = whitewater::readWhitewaterVdb(fuzz::asFile(data, size, ".vdb"));
    if (frame.type.size() != frame.particles.size()) std::abort();
  } catch (const InputError&) {
  }
  return 0;
}
