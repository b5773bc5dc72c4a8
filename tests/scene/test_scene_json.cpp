// Scene format: parse -> write -> parse identity, defaults, presets,
// --set overrides and every kind of validation error.
#include "TestTempDir.h"
#include "libsph/Errors.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/scene/SceneJson.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>

using namespace cascade;
using namespace cascade::scene;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {
const fs::path kScenes = fs::path(CASCADE_SOURCE_DIR) / "scenes";

/// Per process: ctest runs the tests of this file in parallel processes.
fs::path tempPath(const std::string& name) {
  static const fs::path base = cascade::test::freshTempDir("scene");
  return base / name;
}

fs::path tempDir(const std::string& name) {
  const fs::path dir = tempPath(name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

/// Writes `text` as a scene file and returns the message of the InputError
/// loading it throws ("" if it loads).
std::string loadError(const std::string& text, const std::vector<std::string>& sets = {}) {
  const fs::path file = tempDir("error") / "scene.json";
  writeTextAtomically(file, text);
  try {
    loadScene(file, sets);
  } catch (const InputError& error) {
    std::string message = error.what();
    // Make the message independent of the temporary folder.
    const std::string prefix = file.string();
    if (message.rfind(prefix, 0) == 0) message = "scene.json" + message.substr(prefix.size());
    return message;
  }
  return "";
}

const char* kMinimal = R"({"name": "t", "fluid": {"blocks": [{"min": [0,0,0], "max": [0.1,0.1,0.1]}]}})";
} // namespace

TEST(SceneJson, ShippedScenesRoundTrip) {
  for (const char* name : {"bunny.json", "tower.json", "dambreak.json", "hydrostatic.json"}) {
    for (const char* size : {"seed", "production"}) {
      SCOPED_TRACE(std::string(name) + " " + size);
      const Scene first = loadScene(kScenes / name, {std::string("size=") + size});
      const json written = sceneToJson(first);
      const fs::path file = tempDir("roundtrip") / "scene.json";
      writeTextAtomically(file, written.dump(2));
      const Scene second = readResolvedScene(file);
      EXPECT_EQ(sceneToJson(second), written);
      EXPECT_EQ(second.fluid.blocks.size(), first.fluid.blocks.size());
      EXPECT_EQ(second.fluid.spacing, first.fluid.spacing);
      EXPECT_EQ(second.boundaries.obstacles.size(), first.boundaries.obstacles.size());
    }
  }
}

TEST(SceneJson, DefaultsAreFilledAndWritten) {
  const fs::path file = tempDir("defaults") / "scene.json";
  writeTextAtomically(file, kMinimal);
  const Scene scene = loadScene(file);
  const json written = sceneToJson(scene);
  EXPECT_EQ(written["solver"]["type"], "wcsph");
  EXPECT_EQ(written["output"]["fps"], 30.0);
  EXPECT_TRUE(written["camera"].contains("fov"));
  EXPECT_EQ(written["lights"].size(), 2u);
  EXPECT_EQ(written["fluid"]["blocks"][0]["velocity"], json::array({0.0, 0.0, 0.0}));
  EXPECT_TRUE(written["boundaries"]["tank"].is_null());
  // Exact doubles survive the text form.
  EXPECT_EQ(written["gravity"][2].get<double>(), -9.81);
}

// The support factor is the solver's own unless the scene gives one: WCSPH 2.15 spacings
// (at 2 its resting lattice is rigid in shear: docs/solvers.md, "Gravity waves"), DFSPH 2.
TEST(SceneJson, SupportFactorDefaultsToTheSolversOwn) {
  const fs::path file = tempDir("support") / "scene.json";
  writeTextAtomically(file, kMinimal);
  const Scene wcsph = loadScene(file);
  EXPECT_DOUBLE_EQ(wcsph.solver.supportFactor, 2.15);
  EXPECT_DOUBLE_EQ(sceneToJson(wcsph)["solver"]["support_factor"].get<double>(), 2.15);
  EXPECT_DOUBLE_EQ(loadScene(file, {"solver.type=dfsph"}).solver.supportFactor, 2.0);
  EXPECT_DOUBLE_EQ(loadScene(file, {"solver.support_factor=2"}).solver.supportFactor, 2.0);
  EXPECT_DOUBLE_EQ(loadScene(file, {"solver.type=dfsph", "solver.support_factor=2.5"}).solver.supportFactor, 2.5);
  EXPECT_DOUBLE_EQ(loadScene(file, {"solver.support_factor=2.5", "solver.type=dfsph"}).solver.supportFactor, 2.5);
  EXPECT_DOUBLE_EQ(loadScene(file, {R"(solver={"type": "dfsph"})", "whitewater={}"}).solver.supportFactor, 2.0);
  // A file that gives the support keeps it whatever the type.
  const fs::path given = tempDir("support-given") / "scene.json";
  writeTextAtomically(given, R"({"name": "t", "solver": {"support_factor": 2.15},
    "fluid": {"blocks": [{"min": [0,0,0], "max": [0.1,0.1,0.1]}]}})");
  EXPECT_DOUBLE_EQ(loadScene(given, {"solver.type=dfsph"}).solver.supportFactor, 2.15);
  // The filled-in scene reads back the same (a bake's OUT/scene.json keeps its support).
  const fs::path written = tempDir("support-written") / "scene.json";
  writeTextAtomically(written, sceneToJson(loadScene(file, {"solver.type=dfsph"})).dump(2));
  EXPECT_DOUBLE_EQ(readResolvedScene(written).solver.supportFactor, 2.0);
}

TEST(SceneJson, PresetsAndSetOverrides) {
  const fs::path file = tempDir("presets") / "scene.json";
  writeTextAtomically(file, R"({"name": "p", "size": "production",
    "presets": {"seed": {"fluid.spacing": 0.05}, "production": {"fluid.spacing": 0.01}},
    "fluid": {"blocks": [{"min": [0,0,0], "max": [1,1,1]}]}})");
  EXPECT_EQ(loadScene(file).fluid.spacing, 0.01);
  EXPECT_EQ(loadScene(file, {"size=seed"}).fluid.spacing, 0.05);
  EXPECT_EQ(loadScene(file, {"size=seed"}).size, "seed");
  // --set wins over the preset; values are JSON, else strings.
  const Scene set = loadScene(file, {"size=seed", "fluid.spacing=0.02", "solver.eos=tait",
                                     "fluid.blocks.0.velocity=[1,2,3]", "solver.slip=\"no\""});
  EXPECT_EQ(set.fluid.spacing, 0.02);
  EXPECT_EQ(set.solver.eos, "tait");
  EXPECT_EQ(set.solver.slip, "no");
  EXPECT_EQ(set.fluid.blocks[0].velocity[1], 2.0);
  // Bracket form of an index, and setting a null optional with an object.
  const Scene tank = loadScene(file, {"fluid.blocks[0].velocity=[0,0,-1]",
                                      R"(boundaries.tank={"min":[-1,-1,-1],"max":[2,2,2]})"});
  EXPECT_EQ(tank.fluid.blocks[0].velocity[2], -1.0);
  ASSERT_TRUE(tank.boundaries.tank.has_value());
  EXPECT_EQ(tank.boundaries.tank->max[0], 2.0);
}

TEST(SceneJson, AnExplicitValueBeatsThePreset) {
  // The scene file's own fluid.spacing wins over the chosen preset's, and an invalid
  // one is refused whatever the preset.
  const fs::path file = tempDir("explicit") / "scene.json";
  const auto scene = [&](const std::string& spacing) {
    writeTextAtomically(file, R"({"name": "p", "size": "production",
      "presets": {"seed": {"fluid.spacing": 0.05, "solver.cfl": 0.3}, "production": {"fluid.spacing": 0.01}},
      "fluid": {"spacing": )" + spacing + R"(, "blocks": [{"min": [0,0,0], "max": [1,1,1]}]}})");
    return file;
  };
  EXPECT_EQ(loadScene(scene("0.05")).fluid.spacing, 0.05);
  const Scene seed = loadScene(scene("0.04"), {"size=seed"});
  EXPECT_EQ(seed.fluid.spacing, 0.04);
  EXPECT_EQ(seed.solver.cfl, 0.3);  // the preset's other keys still apply
  EXPECT_EQ(loadScene(scene("0.04"), {"size=seed", "fluid.spacing=0.03"}).fluid.spacing, 0.03);  // --set beats both
  for (const char* bad : {"-1", "\"abc\""}) {
    try {
      loadScene(scene(bad));
      ADD_FAILURE() << "spacing " << bad << " was accepted";
    } catch (const InputError& error) {
      EXPECT_NE(std::string(error.what()).find("fluid.spacing: must be"), std::string::npos) << error.what();
    }
  }
}

TEST(SceneJson, UnknownKeySuggestsNearest) {
  EXPECT_EQ(loadError(R"({"name": "t", "fluid": {"spacng": 0.01, "blocks": [{"min": [0,0,0], "max": [1,1,1]}]}})"),
            "scene.json: fluid.spacng: unknown key (did you mean 'spacing'?)");
  EXPECT_EQ(loadError(R"({"name": "t", "fluid": {"blocks": [{"min": [0,0,0], "max": [1,1,1], "velocty": [0,0,0]}]}})"),
            "scene.json: fluid.blocks[0].velocty: unknown key (did you mean 'velocity'?)");
  EXPECT_EQ(loadError(R"({"name": "t", "solvr": {}, "fluid": {"blocks": [{"min": [0,0,0], "max": [1,1,1]}]}})"),
            "scene.json: solvr: unknown key (did you mean 'solver'?)");
  // A misspelt required block is named as unknown, not reported missing.
  EXPECT_EQ(loadError(R"({"name": "t", "fluidd": {"blocks": [{"min": [0,0,0], "max": [1,1,1]}]}})"),
            "scene.json: fluidd: unknown key (did you mean 'fluid'?)");
}

TEST(SceneJson, WrongTypes) {
  EXPECT_EQ(loadError(R"({"name": "t", "fluid": {"spacing": "fine", "blocks": [{"min": [0,0,0], "max": [1,1,1]}]}})"),
            "scene.json: fluid.spacing: must be a number (got \"fine\")");
  EXPECT_EQ(loadError(R"({"name": "t", "fluid": {"blocks": [{"min": [0,0], "max": [1,1,1]}]}})"),
            "scene.json: fluid.blocks[0].min: must be an array of 3 numbers (got [0,0])");
  EXPECT_EQ(loadError(R"({"name": "t", "fluid": {"blocks": {"min": [0,0,0]}}})"),
            "scene.json: fluid.blocks: must be an array (got {\"min\":[0,0,0]})");
  EXPECT_EQ(loadError(R"({"name": "t", "solver": {"clamp_negative_pressure": 1}, "fluid": {"blocks": [{"min": [0,0,0], "max": [1,1,1]}]}})"),
            "scene.json: solver.clamp_negative_pressure: must be true or false (got 1)");
}

TEST(SceneJson, OutOfRangeAndChoices) {
  EXPECT_EQ(loadError(R"({"name": "t", "fluid": {"spacing": -1, "blocks": [{"min": [0,0,0], "max": [1,1,1]}]}})"),
            "scene.json: fluid.spacing: must be > 0 (got -1)");
  EXPECT_EQ(loadError(R"({"name": "t", "solver": {"cfl": 3}, "fluid": {"blocks": [{"min": [0,0,0], "max": [1,1,1]}]}})"),
            "scene.json: solver.cfl: must be in [0.001, 1] (got 3)");
  EXPECT_EQ(loadError(R"({"name": "t", "solver": {"type": "wcsh"}, "fluid": {"blocks": [{"min": [0,0,0], "max": [1,1,1]}]}})"),
            "scene.json: solver.type: must be one of wcsph, dfsph (got \"wcsh\") (did you mean 'wcsph'?)");
  EXPECT_EQ(loadError(R"({"name": "t", "fluid": {"blocks": [{"min": [0,0,0], "max": [1,-1,1]}]}})"),
            "scene.json: fluid.blocks[0].max: must exceed min in every axis");
  EXPECT_EQ(loadError(R"({"name": "t", "fluid": {}})"), "scene.json: fluid: needs at least one block or emitter");
  EXPECT_EQ(loadError(R"({"name": "t", "probes": [{"name": "F", "type": "force", "obstacle": "towr"}],
                          "fluid": {"blocks": [{"min": [0,0,0], "max": [1,1,1]}]}})"),
            "scene.json: probes[0].obstacle: no obstacle named \"towr\"");
}

// A pressure probe's sensor face: its radius, and the normal of the tank wall it sits on
// (or its own); written out and read back; a face off every wall without a normal is named.
TEST(SceneJson, PressureProbeFaceTakesItsWallsNormal) {
  const char* text = R"({"name": "t", "fluid": {"spacing": 0.01, "blocks": [{"min": [0,0,0], "max": [0.5,0.2,0.2]}]},
                         "boundaries": {"tank": {"min": [0,0,0], "max": [1,0.2,0.5]}},
                         "probes": [{"name": "P", "type": "pressure", "at": [1, 0.1, 0.015], "radius": 0.004},
                                    {"name": "F", "type": "pressure", "at": [0.3, 0.1, 0.0], "radius": 0.004},
                                    {"name": "N", "type": "pressure", "at": [0.3, 0.1, 0.1], "radius": 0.002,
                                     "normal": [0, 1, 0]},
                                    {"name": "Q", "type": "pressure", "at": [0.3, 0.1, 0.1]}]})";
  const scene::Scene scene = scene::parseScene(nlohmann::json::parse(text), "scene.json", ".");
  ASSERT_EQ(scene.probes.size(), 4u);
  EXPECT_EQ(scene.probes[0].radius, 0.004);
  EXPECT_EQ(scene.probes[0].normal, (scene::Vec3{-1, 0, 0}));  // the far wall x = 1, facing the water
  EXPECT_EQ(scene.probes[1].normal, (scene::Vec3{0, 0, 1}));   // the floor
  EXPECT_EQ(scene.probes[2].normal, (scene::Vec3{0, 1, 0}));   // its own
  EXPECT_EQ(scene.probes[3].radius, 0.0);                      // a point
  const scene::Scene back = scene::parseScene(scene::sceneToJson(scene), "OUT/scene.json", ".");
  EXPECT_EQ(back.probes[0].normal, scene.probes[0].normal);
  EXPECT_EQ(back.probes[1].radius, 0.004);
  EXPECT_EQ(loadError(R"({"name": "t", "fluid": {"blocks": [{"min": [0,0,0], "max": [1,1,1]}]},
                          "probes": [{"name": "P", "type": "pressure", "at": [0.5, 0.5, 0.5], "radius": 0.01}]})"),
            "scene.json: probes[0].normal: a pressure probe with a radius needs the sensor face's normal (its centre "
            "is not on a tank wall)");
  EXPECT_EQ(loadError(R"({"name": "t", "fluid": {"blocks": [{"min": [0,0,0], "max": [1,1,1]}]},
                          "probes": [{"name": "P", "type": "pressure", "at": [0.5, 0.5, 0.5], "radius": -1}]})"),
            "scene.json: probes[0].radius: must be >= 0 (got -1)");
}

// Numbers beyond any shot (a typo, a unit mistake) are named, as are numbers a double
// cannot hold, in the file and in --set: never a NaN in the solver or the camera.
TEST(SceneJson, AbsurdAndOverflowingNumbersAreNamed) {
  const std::string fluid = R"("fluid": {"blocks": [{"min": [0,0,0], "max": [1,1,1]}]})";
  EXPECT_EQ(loadError(R"({"name": "t", "camera": {"position": [1e30, 0, 0]}, )" + fluid + "}"),
            "scene.json: camera.position[0]: absurd magnitude (got 1e+30; at most 1e+06)");
  EXPECT_EQ(loadError(R"({"name": "t", "gravity": [0, 0, -1e5], )" + fluid + "}"),
            "scene.json: gravity: absurd magnitude (|g| = 100000 m/s^2; at most 1000)");
  EXPECT_EQ(loadError(R"({"name": "t", "solver": {"stiffness": 1e12}, )" + fluid + "}"),
            "scene.json: solver.stiffness: absurd magnitude (got 1e+12; at most 1e+09)");
  EXPECT_EQ(loadError(R"({"name": "t", "probes": [{"name": "P", "type": "pressure", "at": [0, 0, 1e7]}], )" + fluid +
                      "}"),
            "scene.json: probes[0].at[2]: absurd magnitude (got 1e+07; at most 1e+06)");
  EXPECT_EQ(loadError(R"({"name": "t", "lights": [{"type": "directional", "intensity": 1e999}], )" + fluid + "}"),
            "scene.json: invalid JSON: number overflow parsing '1e999'");
  EXPECT_EQ(loadError(std::string(kMinimal), {"fluid.spacing=1e999"}),
            "--set fluid.spacing=1e999: the number overflows a double");
}

// Found by fuzz_scene: a --set value that is not JSON is taken as a string, and one
// that is not UTF-8 made a later dump of the scene throw outside InputError (abort).
TEST(SceneJson, ASetValueThatIsNotUtf8IsRefused) {
  EXPECT_EQ(loadError(std::string(kMinimal), {"name=caf\xe9"}), "--set name: the value is not valid UTF-8");
  EXPECT_EQ(loadError(std::string(kMinimal), {"whitewater={}", "whitewater.limits=\xe8uto"}),
            "--set whitewater.limits: the value is not valid UTF-8");
  EXPECT_EQ(loadError(std::string(kMinimal), {"name=caf\xc3\xa9"}), "");  // UTF-8 is fine
}

TEST(SceneJson, SurfaceSettingsAreReadCheckedAndWritten) {
  const scene::Scene scene = scene::parseScene(
      nlohmann::json::parse(R"({"name": "t", "fluid": {"blocks": [{"min": [0,0,0], "max": [1,1,1]}]},
                                "surface": {"mesh_format": "ply", "outputs": "mesh", "velocity": false,
                                            "adaptivity": 0.25}})"),
      "scene.json", ".");
  EXPECT_EQ(scene.surface.meshFormat, "ply");
  EXPECT_EQ(scene.surface.outputs, "mesh");
  EXPECT_FALSE(scene.surface.velocity);
  EXPECT_EQ(scene.surface.adaptivity, 0.25);
  EXPECT_EQ(scene.surface.method, "anisotropic");  // the default, written out
  const nlohmann::json written = scene::sceneToJson(scene);
  EXPECT_EQ(written["surface"]["method"], "anisotropic");
  const scene::SurfaceSettings back = scene::parseSurfaceSettings(written["surface"], "OUT/scene.json");
  EXPECT_EQ(back.meshFormat, "ply");
  EXPECT_EQ(back.outputs, "mesh");
  EXPECT_EQ(back.adaptivity, 0.25);
  EXPECT_EQ(loadError(R"({"name": "t", "surface": {"mesh_format": "plyy"},
                          "fluid": {"blocks": [{"min": [0,0,0], "max": [1,1,1]}]}})"),
            "scene.json: surface.mesh_format: must be one of obj, ply (got \"plyy\") (did you mean 'ply'?)");
  EXPECT_EQ(loadError(R"({"name": "t", "surface": {"adaptivity": 2},
                          "fluid": {"blocks": [{"min": [0,0,0], "max": [1,1,1]}]}})"),
            "scene.json: surface.adaptivity: must be in [0, 1] (got 2)");
  EXPECT_EQ(loadError(R"({"name": "t", "surface": {"output": "vdb"},
                          "fluid": {"blocks": [{"min": [0,0,0], "max": [1,1,1]}]}})"),
            "scene.json: surface.output: unknown key (did you mean 'outputs'?)");
}

TEST(SceneJson, WhitewaterBlockIsReadCheckedAndWritten) {
  const nlohmann::json withBlock = nlohmann::json::parse(
      R"({"name": "t", "fluid": {"blocks": [{"min": [0,0,0], "max": [1,1,1]}]},
          "whitewater": {"rate_scale": 2.5, "lifetime": [1, 4], "limits": "fixed"}})");
  const scene::Scene scene = scene::parseScene(withBlock, "scene.json", ".");
  ASSERT_TRUE(scene.whitewater.has_value());
  EXPECT_EQ(scene.whitewater->rateScale, 2.5);
  EXPECT_EQ(scene.whitewater->lifetime, (std::array<double, 2>{1, 4}));
  EXPECT_EQ(scene.whitewater->limits, "fixed");
  EXPECT_EQ(scene.whitewater->sprayNeighbors, 6);  // the paper's, filled in
  const nlohmann::json written = scene::sceneToJson(scene);
  const scene::WhitewaterSettings back = scene::parseWhitewaterSettings(written["whitewater"], "OUT/scene.json");
  EXPECT_EQ(scene::whitewaterSettingsToJson(back), written["whitewater"]);
  // No block: no stage, written as null (and read back as absent).
  const scene::Scene without = scene::parseScene(nlohmann::json::parse(kMinimal), "scene.json", ".");
  EXPECT_FALSE(without.whitewater.has_value());
  EXPECT_TRUE(scene::sceneToJson(without)["whitewater"].is_null());
  const auto bad = [](const std::string& block) {
    return loadError(R"({"name": "t", "fluid": {"blocks": [{"min": [0,0,0], "max": [1,1,1]}]}, "whitewater": )" +
                     block + "}");
  };
  EXPECT_EQ(bad(R"({"lifetime": [5, 2]})"), "scene.json: whitewater.lifetime: min must be <= max (got [5, 2])");
  EXPECT_EQ(bad(R"({"trapped_air": [3, 3]})"), "scene.json: whitewater.trapped_air: min must be < max (got [3, 3])");
  EXPECT_EQ(bad(R"({"wave_crest_rate": -1})"), "scene.json: whitewater.wave_crest_rate: must be >= 0 (got -1)");
  EXPECT_EQ(bad(R"({"spray_neighbors": 30})"),
            "scene.json: whitewater.bubble_neighbors: must be >= spray_neighbors (got 20 < 30)");
  EXPECT_EQ(bad(R"({"rate_scal": 2})"), "scene.json: whitewater.rate_scal: unknown key (did you mean 'rate_scale'?)");
}

TEST(SceneJson, AnObjectSetWholeTakesItsDefaultsForLaterSets) {
  const fs::path file = tempDir("whitewater_set") / "scene.json";
  writeTextAtomically(file, kMinimal);
  const scene::Scene scene = scene::loadScene(file, {"whitewater={}", "whitewater.rate_scale=3"});
  ASSERT_TRUE(scene.whitewater.has_value());
  EXPECT_EQ(scene.whitewater->rateScale, 3);
  EXPECT_EQ(scene.whitewater->lifetime, (std::array<double, 2>{2, 5}));
}

TEST(SceneJson, SetErrors) {
  EXPECT_EQ(loadError(kMinimal, {"fluid.spacingg=0.1"}),
            "--set fluid.spacingg: unknown key 'fluid.spacingg' (did you mean 'fluid.spacing'?)");
  EXPECT_EQ(loadError(kMinimal, {"fluid.blocks.3.min=[0,0,0]"}),
            "--set fluid.blocks.3.min: fluid.blocks has 1 entries (index 3 out of range)");
  EXPECT_EQ(loadError(kMinimal, {"fluid.spacing=-2"}), "scene.json: fluid.spacing: must be > 0 (got -2)");
  EXPECT_EQ(loadError(kMinimal, {"fluid.spacing"}), "--set fluid.spacing: expected KEY=VALUE");
}

TEST(SceneJson, MissingAssetNamesThePath) {
  const std::string message = loadError(R"({"name": "t", "fluid": {"blocks": [{"min": [0,0,0], "max": [1,1,1]}]},
      "boundaries": {"obstacles": [{"name": "rock", "mesh": "assets/rock.obj"}]}})");
  const fs::path lookedFor = (tempPath("error") / "assets" / "rock.obj").lexically_normal();
  EXPECT_EQ(message, "scene.json: boundaries.obstacles[0].mesh: mesh file not found: " + lookedFor.string());
}

TEST(SceneJson, BrokenJsonAndMissingFile) {
  EXPECT_NE(loadError("{\"name\": \"t\",\n \"fluid\": {").find("scene.json: invalid JSON: parse error at line 2"),
            std::string::npos);
  EXPECT_THROW(loadScene("/nonexistent/scene.json"), InputError);
}
