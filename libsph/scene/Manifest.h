/// @file Manifest.h
/// @brief OUT/manifest.json (docs/cli.md: "stages done, their input hashes,
///        timings") and the input hashes `cascade run` uses to skip a stage
///        whose inputs did not change.
///
/// Layout: {"scene": NAME, "stages": {"bake": {"done": true, "input_hash":
/// "...", "seconds": 12.5, "frames": 60, ...}, "surface": {...}, "render": {...}}}.
/// Every update rewrites the file atomically (read, modify, rename).
#pragma once

#include "libsph/scene/Scene.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace cascade::scene {

/// 64-bit FNV-1a over bytes (continuing from `hash`).
std::uint64_t fnv1a(const void* data, std::size_t size, std::uint64_t hash = 0xcbf29ce484222325ull);

/// 16 hex digits.
std::string hexHash(std::uint64_t hash);

/// Hash of everything a bake reads: the resolved scene JSON but for what only
/// later stages read (surface, whitewater, camera, lights) and the mesh files'
/// paths, and the bytes of every mesh file it names. Where the files are does not
/// enter: a scene folder moved elsewhere (a farm node's mount) keeps its hash.
std::string sceneInputHash(const Scene& scene);
/// The same from the obstacles' meshContentHashes(), for a caller that has them.
std::string sceneInputHash(const Scene& scene, const std::vector<std::string>& meshHashes);

/// Hash of an obstacle's mesh bytes (every frame of a deforming sequence up to
/// `frameCount`), 16 hex digits; a file that cannot be read adds nothing.
std::string meshContentHash(const Obstacle& obstacle, int frameCount);
/// meshContentHash() of every obstacle of the scene, in order.
std::vector<std::string> meshContentHashes(const Scene& scene);
/// Hash of what `cascade surface` reads: the bake's inputs (`bakeHash`) and the
/// scene's surface settings.
std::string surfaceInputHash(const Scene& scene, const std::string& bakeHash);
/// Hash of what `cascade whitewater` reads: the bake's inputs and the scene's
/// whitewater settings.
std::string whitewaterInputHash(const Scene& scene, const std::string& bakeHash);
/// Hash of what `cascade render` reads: the surface stage's inputs (`surfaceHash`),
/// the whitewater stage's (`whitewaterHash`, empty without one), the camera and the lights.
std::string renderInputHash(const Scene& scene, const std::string& surfaceHash,
                            const std::string& whitewaterHash = "");

/// The four stages' input hashes as `cascade run` and `cascade farm` chain them:
/// whitewater (empty when `withWhitewater` is false or the scene has no block) and
/// surface after the bake (the surface after the whitewater when it makes a foam
/// grid), render after the surface and the whitewater.
struct StageHashes {
  std::string bake, whitewater, surface, render;
};
StageHashes stageInputHashes(const Scene& scene, const std::vector<std::string>& meshHashes, bool withWhitewater);

/// The manifest at `path`, or an empty one ({"stages": {}}) if it does not
/// exist or cannot be parsed.
nlohmann::json readManifest(const std::filesystem::path& path);

/// Sets manifest["stages"][stage] = record (and "scene"), atomically.
void recordStage(const std::filesystem::path& path, const std::string& sceneName,
                 const std::string& stage, const nlohmann::json& record);

/// True if the manifest says `stage` is done with this input hash.
bool stageIsCurrent(const nlohmann::json& manifest, const std::string& stage,
                    const std::string& inputHash);

} // namespace cascade::scene
