/// @file SceneJson.h
/// @brief The JSON scene format (README "Scenes"): parsing with validation,
///        writing with every default filled in, size presets and `--set`.
///
/// Validation errors are InputError with one line naming the file and the
/// JSON path of the bad value, e.g.
///   scene.json: fluid.spacing: must be > 0 (got -1)
///   scene.json: fluid.spacng: unknown key (did you mean 'spacing'?)
///
/// Loading a scene file (loadScene):
///  1. read the JSON; a `--set size=NAME` replaces the top-level "size";
///  2. if the file has "presets": {"seed": {"fluid.spacing": 0.02, ...}, ...},
///     the entries of presets[size] (dotted paths, like --set) are applied and
///     "presets" is dropped;
///  3. parse and validate, filling every default (mesh paths resolved against
///     the scene file's folder and made absolute; a missing file is an error);
///  4. every other `--set PATH=VALUE` replaces the value at PATH of the
///     default-filled scene (VALUE parsed as JSON, else taken as a string);
///     a PATH that does not exist there is an error; then validate again.
/// The result written by sceneToJson() parses back to the same scene
/// (parse -> write -> parse is the identity). Absent optional objects and the
/// unused one of two alternatives are written as null (read as absent) so that
/// `--set` can reach them: boundaries.tank, boundaries.obstacles[i].motion /
/// .dynamic, motion.keyframes / motion.piston, dynamic.density / dynamic.mass.
#pragma once

#include "libsph/scene/Scene.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>
#include <vector>

namespace cascade::scene {

/// The solver types a scene may name ("wcsph", "dfsph", ...); extend in SceneJson.cpp.
const std::vector<std::string>& solverTypes();
/// The neighbour search methods a scene may name (solver.neighbor_search).
const std::vector<std::string>& neighborSearchNames();

/// Parses a scene from JSON; `fileLabel` prefixes every error message and
/// relative mesh paths are resolved against `baseDir`. Throws InputError.
Scene parseScene(const nlohmann::json& json, const std::string& fileLabel,
                 const std::filesystem::path& baseDir);

/// The scene as JSON with every value present (the form of OUT/scene.json).
nlohmann::json sceneToJson(const Scene& scene);

/// The "surface" block (surfacing defaults; `cascade surface` reads it from
/// OUT/scene.json). Throws InputError naming `fileLabel` and the key.
SurfaceSettings parseSurfaceSettings(const nlohmann::json& json, const std::string& fileLabel);
nlohmann::json surfaceSettingsToJson(const SurfaceSettings& settings);

/// The "whitewater" block ({} takes every default). Throws InputError naming
/// `fileLabel` and the key.
WhitewaterSettings parseWhitewaterSettings(const nlohmann::json& json, const std::string& fileLabel);
nlohmann::json whitewaterSettingsToJson(const WhitewaterSettings& settings);

/// Replaces the value at a dotted path ("fluid.blocks.0.min" or
/// "fluid.blocks[0].min") of `json` by `value` (parsed as JSON, else a string).
/// With mustExist, a path not present in `json` is an InputError naming
/// `label` (e.g. "--set"); otherwise missing objects are created.
void setJsonPath(nlohmann::json& json, const std::string& path, const std::string& value,
                 const std::string& label, bool mustExist);
void setJsonPath(nlohmann::json& json, const std::string& path, const nlohmann::json& value,
                 const std::string& label, bool mustExist);

/// Loads a scene file with its presets and `--set KEY=VALUE` overrides (see above).
Scene loadScene(const std::filesystem::path& file, const std::vector<std::string>& overrides = {});
/// The same for a scene's text: `label` names it in errors, mesh paths are relative to `baseDir`.
Scene loadSceneText(const std::string& text, const std::string& label, const std::filesystem::path& baseDir,
                    const std::vector<std::string>& overrides = {});

/// Reads OUT/scene.json (a resolved scene) without presets or overrides. Its mesh
/// paths are relative to its folder; a mesh file that is not there is no error
/// (the stages after the bake read OUT/geometry, not the meshes).
Scene readResolvedScene(const std::filesystem::path& file);

/// Writes OUT/scene.json atomically: sceneToJson() with every obstacle's mesh path
/// relative to the file's folder and its content hash ("mesh_hash",
/// meshContentHash()), so that a bake folder moved with its assets re-runs.
/// Returns what it wrote.
/// `meshHashes`: meshContentHashes(scene), which the caller usually has already.
nlohmann::json writeResolvedScene(const Scene& scene, const std::filesystem::path& file,
                                  const std::vector<std::string>& meshHashes);
/// What writeResolvedScene() writes to `file`, without writing it.
nlohmann::json resolvedScene(const Scene& scene, const std::filesystem::path& file,
                             const std::vector<std::string>& meshHashes);

/// Levenshtein edit distance (for "did you mean" suggestions).
std::size_t editDistance(const std::string& a, const std::string& b);

/// The candidate nearest to `word`, or "" if none is reasonably close.
std::string nearestWord(const std::string& word, const std::vector<std::string>& candidates);

} // namespace cascade::scene
