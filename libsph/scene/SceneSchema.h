/// @file SceneSchema.h
/// @brief The scene format's reference, made from the parser itself: every key
///        it reads, with kind, default and limits, joined with a table of units
///        and meanings. `cascade schema` prints it as a JSON Schema (for
///        editors), `cascade schema --markdown` as docs/scenes.md.
///
/// The parser notes each key it reads (SceneJson.cpp, ObjectReader). sceneKeys()
/// parses a built-in scene that takes every branch (each probe type, motion,
/// light...) with the notes on, and joins them with the documentation table
/// (SceneSchema.cpp); a key noted but not documented, or documented but never
/// read, is a std::logic_error, so the reference cannot drift from the parser.
#pragma once

#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace cascade::scene {

/// One key of the scene format.
struct SceneKey {
  std::string path;             ///< dotted, array items as []: "fluid.blocks[].min"
  std::string kind;             ///< object, array, number, integer, boolean, string, enum, vector (any: untyped)
  int size = 0;                 ///< vector: its length; 0: 2 or 3
  nlohmann::json fallback;      ///< the default (null: none)
  bool required = false;
  std::optional<double> minimum, maximum;  ///< for a vector: of each number
  bool exclusiveMinimum = false;
  std::vector<std::string> choices;        ///< enum
  std::string unit, description, defaultText;  ///< from the documentation table
};

/// The keys the parser reads from `scene` (a resolved scene whose mesh paths are
/// relative to `baseDir`; the files need not exist), in reading order, without
/// documentation. Throws InputError if the scene is invalid.
std::vector<SceneKey> keysReadFrom(const nlohmann::json& scene, const std::filesystem::path& baseDir);

/// Every key of the scene format, documented (see above); "presets" is added,
/// since loadScene() applies it before parsing.
const std::vector<SceneKey>& sceneKeys();

/// sceneKeys() as a JSON Schema (draft 2020-12): unknown keys are refused, null
/// stands for an absent optional key, as in OUT/scene.json.
nlohmann::json sceneJsonSchema();

/// docs/scenes.md: sceneKeys() as tables, one per block, after an introduction.
std::string sceneKeysMarkdown();

} // namespace cascade::scene
