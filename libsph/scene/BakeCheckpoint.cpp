#include "libsph/scene/BakeCheckpoint.h"

#include "libsph/Errors.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/solver/Simulation.h"

#include <cstring>
#include <fstream>

namespace cascade::scene {

namespace fs = std::filesystem;

namespace {
constexpr char kMagic[8] = {'C', 'A', 'S', 'C', 'K', 'P', 'T', '1'};

template <typename T>
void put(std::ostream& out, const T& value) {
  out.write(reinterpret_cast<const char*>(&value), sizeof value);
}
void putString(std::ostream& out, const std::string& text) {
  put<std::uint64_t>(out, text.size());
  out.write(text.data(), std::streamsize(text.size()));
}
template <typename T>
void get(std::istream& in, T& value) {
  in.read(reinterpret_cast<char*>(&value), sizeof value);
  if (!in) throw std::runtime_error("truncated");
}
void getString(std::istream& in, std::string& text) {
  std::uint64_t size = 0;
  get(in, size);
  if (size > (1ull << 34)) throw std::runtime_error("corrupt string length");
  text.resize(size);
  in.read(text.data(), std::streamsize(size));
  if (!in) throw std::runtime_error("truncated");
}

BakeCheckpoint readHeader(std::istream& in) {
  char magic[8];
  in.read(magic, 8);
  if (!in || std::memcmp(magic, kMagic, 8) != 0) throw std::runtime_error("not a Cascade bake checkpoint");
  BakeCheckpoint checkpoint;
  getString(in, checkpoint.inputHash);
  std::int32_t frame = 0;
  get(in, frame);
  checkpoint.frame = frame;
  std::uint64_t emitterCount = 0;
  get(in, emitterCount);
  if (emitterCount > 100000) throw std::runtime_error("corrupt emitter count");
  checkpoint.emitters.resize(emitterCount);
  for (EmitterState& state : checkpoint.emitters) {
    get(in, state.layers);
    get(in, state.emitted);
  }
  get(in, checkpoint.killed);
  get(in, checkpoint.probeSamples);
  getString(in, checkpoint.probeRows);
  get(in, checkpoint.wallSeconds);
  return checkpoint;
}
} // namespace

fs::path checkpointPath(const fs::path& outDir) { return outDir / ".checkpoint" / "bake.ckpt"; }

void writeCheckpoint(const fs::path& path, const BakeCheckpoint& checkpoint, const Simulation& simulation) {
  writeFileAtomically(path, [&](const fs::path& temp) {
    std::ofstream out(temp, std::ios::binary);
    out.write(kMagic, 8);
    putString(out, checkpoint.inputHash);
    put<std::int32_t>(out, checkpoint.frame);
    put<std::uint64_t>(out, checkpoint.emitters.size());
    for (const EmitterState& state : checkpoint.emitters) {
      put(out, state.layers);
      put(out, state.emitted);
    }
    put(out, checkpoint.killed);
    put(out, checkpoint.probeSamples);
    putString(out, checkpoint.probeRows);
    put(out, checkpoint.wallSeconds);
    simulation.save(out);
    out.close();
    if (!out) throw std::runtime_error(path.string() + ": cannot write checkpoint");
  });
}

std::optional<BakeCheckpoint> readCheckpointHeader(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  try {
    return readHeader(in);
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

BakeCheckpoint readCheckpoint(const fs::path& path, Simulation& simulation) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string() + ": cannot open checkpoint");
  try {
    BakeCheckpoint checkpoint = readHeader(in);
    simulation.restore(in);
    return checkpoint;
  } catch (const InputError& error) {
    throw InputError(path.string() + ": " + error.what());
  } catch (const std::exception& error) {
    throw InputError(path.string() + ": damaged checkpoint (" + error.what() + ")");
  }
}

} // namespace cascade::scene
