// The scene format's reference (SceneSchema.h): docs/scenes.md is the generated page;
// every key the shipped scenes use is in it; and the JSON Schema agrees with the parser:
// it accepts every shipped scene (as written and as OUT/scene.json) and refuses the
// mistakes the parser refuses.
#include "libsph/Errors.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/scene/SceneJson.h"
#include "libsph/scene/SceneSchema.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

using namespace cascade;
using namespace cascade::scene;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

const fs::path kSource(CASCADE_SOURCE_DIR);

std::vector<fs::path> shippedScenes() {
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(kSource / "scenes"))
    if (entry.path().extension() == ".json") files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  return files;
}

json readJson(const fs::path& file) { return json::parse(readTextFile(file)); }

/// A JSON Schema check of the keywords sceneJsonSchema() uses (anyOf, enum, type,
/// properties, additionalProperties, required, items, minItems, maxItems, minimum,
/// exclusiveMinimum, maximum). Returns "" if `value` is valid, else where it is not.
std::string violation(const json& schema, const json& value, const std::string& path = "") {
  if (schema.contains("anyOf")) {
    std::string first;
    for (const json& option : schema["anyOf"]) {
      const std::string why = violation(option, value, path);
      if (why.empty()) return "";
      if (first.empty()) first = why;
    }
    return first;
  }
  if (schema.contains("enum")) {
    for (const json& choice : schema["enum"])
      if (choice == value) return "";
    return path + ": not one of " + schema["enum"].dump();
  }
  const std::string type = schema.value("type", "");
  if (type == "null") return value.is_null() ? "" : path + ": not null";
  if (type == "boolean") return value.is_boolean() ? "" : path + ": not a boolean";
  if (type == "string") return value.is_string() ? "" : path + ": not a string";
  if (type == "number" || type == "integer") {
    if (!value.is_number()) return path + ": not a number";
    const double x = value.get<double>();
    if (type == "integer" && std::floor(x) != x) return path + ": not an integer";
    if (schema.contains("minimum") && x < schema["minimum"].get<double>()) return path + ": below minimum";
    if (schema.contains("exclusiveMinimum") && x <= schema["exclusiveMinimum"].get<double>())
      return path + ": not above exclusiveMinimum";
    if (schema.contains("maximum") && x > schema["maximum"].get<double>()) return path + ": above maximum";
    return "";
  }
  if (type == "array") {
    if (!value.is_array()) return path + ": not an array";
    if (schema.contains("minItems") && value.size() < schema["minItems"].get<std::size_t>()) return path + ": too short";
    if (schema.contains("maxItems") && value.size() > schema["maxItems"].get<std::size_t>()) return path + ": too long";
    for (std::size_t i = 0; i < value.size(); ++i) {
      const std::string why = violation(schema["items"], value[i], path + "[" + std::to_string(i) + "]");
      if (!why.empty()) return why;
    }
    return "";
  }
  if (type == "object") {
    if (!value.is_object()) return path + ": not an object";
    for (const json& key : schema.value("required", json::array()))
      if (!value.contains(key.get<std::string>())) return path + "." + key.get<std::string>() + ": missing";
    for (auto it = value.begin(); it != value.end(); ++it) {
      const std::string child = path.empty() ? it.key() : path + "." + it.key();
      const json properties = schema.value("properties", json::object());
      if (properties.contains(it.key())) {
        const std::string why = violation(properties[it.key()], it.value(), child);
        if (!why.empty()) return why;
      } else if (schema.contains("additionalProperties") && schema["additionalProperties"].is_object()) {
        const std::string why = violation(schema["additionalProperties"], it.value(), child);
        if (!why.empty()) return why;
      } else if (schema.value("additionalProperties", json(true)) == json(false)) {
        return child + ": unknown key";
      }
    }
    return "";
  }
  return path + ": schema without a type";
}

} // namespace

TEST(SceneSchema, TheReferencePageIsTheGeneratedOne) {
  EXPECT_EQ(readTextFile(kSource / "docs" / "scenes.md"), sceneKeysMarkdown())
      << "docs/scenes.md is out of date: build/cascade schema --markdown > docs/scenes.md";
}

TEST(SceneSchema, EveryKeyTheShippedScenesUseIsDocumented) {
  std::set<std::string> documented;
  for (const SceneKey& key : sceneKeys()) {
    EXPECT_FALSE(key.description.empty()) << key.path;
    EXPECT_NE(key.kind, "any") << key.path;
    documented.insert(key.path);
  }
  // The top level: exactly the blocks a scene file may hold.
  std::set<std::string> top;
  for (const std::string& path : documented)
    if (path.find_first_of(".[") == std::string::npos) top.insert(path);
  EXPECT_EQ(top, (std::set<std::string>{"boundaries", "camera", "description", "fluid", "gravity", "lights", "name",
                                        "output", "presets", "probes", "size", "solver", "surface", "whitewater"}));
  for (const fs::path& file : shippedScenes()) {
    const json resolved = sceneToJson(loadScene(file));
    for (const SceneKey& key : keysReadFrom(resolved, file.parent_path())) {
      if (key.path.size() > 2 && key.path.substr(key.path.size() - 2) == "[]") continue;
      EXPECT_EQ(documented.count(key.path), 1u) << file.filename() << ": " << key.path;
    }
  }
}

TEST(SceneSchema, TheSchemaAcceptsTheShippedScenesAsWrittenAndResolved) {
  const json schema = sceneJsonSchema();
  for (const fs::path& file : shippedScenes()) {
    EXPECT_EQ(violation(schema, readJson(file)), "") << file.filename();
    EXPECT_EQ(violation(schema, sceneToJson(loadScene(file))), "") << file.filename() << " (resolved)";
  }
}

TEST(SceneSchema, TheSchemaRefusesWhatTheParserRefuses) {
  const json schema = sceneJsonSchema();
  const json base = readJson(kSource / "scenes" / "bunny_drop.json");
  const fs::path folder = kSource / "scenes";
  struct Mistake {
    const char* path;
    json value;
  };
  const std::vector<Mistake> mistakes{
      {"/fluid/spacng", 0.01},
      {"/fluid/spacing", -1},
      {"/fluid/spacing", "abc"},
      {"/solver/type", "sph"},
      {"/solver/cfl", 2},
      {"/solver/max_iterations", 1.5},
      {"/gravity", json::array({0, -9.81})},
      {"/output/fps", 0},
      {"/camera/fov", 180},
      {"/boundaries/obstacles/0/dynamic/restitution", 1.5},
      {"/boundaries/obstacles/0/scale", 0},
      {"/probes", json::array({{{"name", "p"}, {"type", "pressur"}, {"at", {0, 0, 0}}}})},
      {"/surface/outputs", "all"},
      {"/whitewater", {{"substeps", -1}}},
      {"/lights", json::array({{{"type", "spot"}}})},
      {"/fluid/blocks/0/velocity", json::array({1, 2, 3, 4})},
      {"/fluidd", json::object()},
  };
  for (const Mistake& mistake : mistakes) {
    json scene = base;
    scene[json::json_pointer(mistake.path)] = mistake.value;
    EXPECT_NE(violation(schema, scene), "") << mistake.path << " = " << mistake.value.dump();
    json resolved = sceneToJson(loadScene(kSource / "scenes" / "bunny_drop.json"));
    resolved[json::json_pointer(mistake.path)] = mistake.value;
    EXPECT_THROW(parseScene(resolved, "mistake.json", folder), InputError) << mistake.path;
  }
}

// docs/tutorial.md shows scenes/tutorial_splash.json in full; the two stay the same.
TEST(SceneSchema, TheTutorialShowsItsSceneAsShipped) {
  const std::string tutorial = readTextFile(kSource / "docs" / "tutorial.md");
  const std::size_t start = tutorial.find("```json\n");
  ASSERT_NE(start, std::string::npos);
  const std::size_t end = tutorial.find("```", start + 8);
  json shown = json::parse(tutorial.substr(start + 8, end - start - 8));
  json shipped = readJson(kSource / "scenes" / "tutorial_splash.json");
  shipped.erase("description");
  EXPECT_EQ(shown, shipped);
}
