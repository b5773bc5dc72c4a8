#include "libsph/scene/Manifest.h"

#include "libsph/bodies/DeformingMesh.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/scene/SceneJson.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <fstream>
#include <vector>

namespace cascade::scene {

namespace fs = std::filesystem;
using nlohmann::json;

std::uint64_t fnv1a(const void* data, std::size_t size, std::uint64_t hash) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < size; ++i) {
    hash ^= bytes[i];
    hash *= 0x100000001b3ull;
  }
  return hash;
}

std::string hexHash(std::uint64_t hash) {
  char buffer[17];
  std::snprintf(buffer, sizeof buffer, "%016llx", static_cast<unsigned long long>(hash));
  return buffer;
}

namespace {
/// fnv1a of `text`, continuing from the hash written as hex in `previous`.
std::string chainHash(const std::string& text, const std::string& previous) {
  return hexHash(fnv1a(text.data(), text.size(), std::stoull(previous, nullptr, 16)));
}
} // namespace

std::string surfaceInputHash(const Scene& scene, const std::string& bakeHash) {
  return chainHash("surface" + surfaceSettingsToJson(scene.surface).dump(), bakeHash);
}

std::string whitewaterInputHash(const Scene& scene, const std::string& bakeHash) {
  const json settings = scene.whitewater ? whitewaterSettingsToJson(*scene.whitewater) : json(nullptr);
  return chainHash("whitewater" + settings.dump(), bakeHash);
}

std::string renderInputHash(const Scene& scene, const std::string& surfaceHash, const std::string& whitewaterHash) {
  const json view = sceneToJson(scene);
  return chainHash("render" + view["camera"].dump() + view["lights"].dump() + whitewaterHash, surfaceHash);
}

StageHashes stageInputHashes(const Scene& scene, const std::vector<std::string>& meshHashes, bool withWhitewater) {
  StageHashes hashes;
  hashes.bake = sceneInputHash(scene, meshHashes);
  if (scene.whitewater && withWhitewater) hashes.whitewater = whitewaterInputHash(scene, hashes.bake);
  hashes.surface = surfaceInputHash(
      scene, scene.surface.foamDensity && !hashes.whitewater.empty() ? hashes.whitewater : hashes.bake);
  hashes.render = renderInputHash(scene, hashes.surface, hashes.whitewater);
  return hashes;
}

namespace {
/// fnv1a over the obstacle's mesh bytes (every frame of a sequence), continuing from `hash`.
std::uint64_t addMeshBytes(const Obstacle& obstacle, int frameCount, std::uint64_t hash) {
  std::vector<char> buffer(1 << 16);
  const auto addFile = [&](const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    while (in) {
      in.read(buffer.data(), std::streamsize(buffer.size()));
      hash = fnv1a(buffer.data(), std::size_t(in.gcount()), hash);
    }
  };
  if (!obstacle.isSequence()) {
    addFile(obstacle.mesh);
    return hash;
  }
  for (int f = sequenceFirstFrame(obstacle.mesh); f <= frameCount; ++f) addFile(sequenceFramePath(obstacle.mesh, f));
  return hash;
}
} // namespace

std::string meshContentHash(const Obstacle& obstacle, int frameCount) {
  return hexHash(addMeshBytes(obstacle, frameCount, fnv1a("", 0)));
}

std::vector<std::string> meshContentHashes(const Scene& scene) {
  std::vector<std::string> hashes;
  for (const Obstacle& obstacle : scene.boundaries.obstacles)
    hashes.push_back(meshContentHash(obstacle, scene.output.frameCount()));
  return hashes;
}

std::string sceneInputHash(const Scene& scene) { return sceneInputHash(scene, meshContentHashes(scene)); }

std::string sceneInputHash(const Scene& scene, const std::vector<std::string>& meshHashes) {
  json resolved = sceneToJson(scene);
  for (const char* laterStages : {"surface", "whitewater", "camera", "lights"}) resolved.erase(laterStages);
  for (json& obstacle : resolved["boundaries"]["obstacles"]) obstacle.erase("mesh");
  const std::string text = resolved.dump();
  std::uint64_t hash = fnv1a(text.data(), text.size());
  for (const std::string& meshHash : meshHashes) hash = fnv1a(meshHash.data(), meshHash.size(), hash);
  return hexHash(hash);
}

json readManifest(const fs::path& path) {
  json manifest;
  std::ifstream in(path);
  if (in) {
    try {
      in >> manifest;
    } catch (const json::exception&) {
      manifest = json();
    }
  }
  if (!manifest.is_object()) manifest = json::object();
  if (!manifest.contains("stages") || !manifest["stages"].is_object()) manifest["stages"] = json::object();
  return manifest;
}

void recordStage(const fs::path& path, const std::string& sceneName, const std::string& stage,
                 const json& record) {
  // Farm jobs of several stages update one manifest at once: read, modify and
  // rename under an exclusive lock (fcntl, which NFS passes to its lock manager).
  const fs::path lockPath = path.parent_path() / ("." + path.filename().string() + ".lock");
  const int lock = ::open(lockPath.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  struct flock whole {};
  whole.l_type = F_WRLCK;
  whole.l_whence = SEEK_SET;
  if (lock >= 0)
    while (::fcntl(lock, F_SETLKW, &whole) != 0 && errno == EINTR) {
    }
  struct Unlock {
    int fd;
    ~Unlock() {
      if (fd >= 0) ::close(fd);  // closing releases the lock
    }
  } unlock{lock};
  json manifest = readManifest(path);
  manifest["scene"] = sceneName;
  manifest["stages"][stage] = record;
  writeTextAtomically(path, manifest.dump(2) + "\n");
}

bool stageIsCurrent(const json& manifest, const std::string& stage, const std::string& inputHash) {
  const auto stages = manifest.find("stages");
  if (stages == manifest.end() || !stages->contains(stage)) return false;
  const json& record = (*stages)[stage];
  return record.value("done", false) && record.value("input_hash", std::string()) == inputHash;
}

} // namespace cascade::scene
