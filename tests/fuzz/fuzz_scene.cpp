// libFuzzer harness: the scene parser with `--set` overrides (SceneJson.h).
// Input: a scene's JSON text, optionally followed by a line "--set" and one
// KEY=VALUE override per line. Bad input must end in InputError, never in another
// exception or a crash; a scene that loads must survive parse -> write -> parse
// unchanged, and its memory estimate must be a number.
#include "libsph/Errors.h"
#include "libsph/scene/SceneSetup.h"
#include "libsph/scene/SceneJson.h"

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace cascade;
  std::string text(reinterpret_cast<const char*>(data), size);
  std::vector<std::string> overrides;
  const std::size_t marker = text.find("\n--set\n");
  if (marker != std::string::npos) {
    std::istringstream lines(text.substr(marker + 7));
    for (std::string line; std::getline(lines, line);)
      if (!line.empty()) overrides.push_back(line);
    text.resize(marker);
  }
  scene::Scene loaded;
  try {
    loaded = scene::loadSceneText(text, "fuzz.json", CASCADE_SOURCE_DIR "/scenes", overrides);
  } catch (const InputError&) {
    return 0;
  }
  const nlohmann::json written = scene::sceneToJson(loaded);
  const scene::Scene again = scene::parseScene(written, "again.json", CASCADE_SOURCE_DIR "/scenes");
  if (scene::sceneToJson(again) != written) std::abort();  // parse -> write -> parse is the identity
  const scene::MemoryEstimate memory = scene::estimateBakeMemory(loaded);
  if (!(memory.bytes >= 0)) std::abort();
  return 0;
}
