// Scene format for moving obstacles and rigid bodies: boundaries.obstacles[i].motion
// (keyframes or a piston), .dynamic (density or mass), the "body" and "velocity"
// probes, their validation errors, the written form and --set overrides.
#include "TestTempDir.h"
#include "libsph/Errors.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/scene/SceneJson.h"

#include <gtest/gtest.h>

#include <filesystem>

using namespace cascade;
using namespace cascade::scene;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

/// Per process: ctest runs the tests of this file in parallel processes.
fs::path tempDir(const std::string& name) {
  static const fs::path base = cascade::test::freshTempDir("scene_motion");
  const fs::path dir = base / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

/// A scene with one block of water and the given obstacles / probes (JSON
/// array texts); the obstacles may use the mesh "cube.obj" next to the file.
std::string sceneText(const std::string& obstacles, const std::string& probes = "[]") {
  return R"({"name": "m", "fluid": {"blocks": [{"min": [0,0,0], "max": [0.1,0.1,0.1]}]},
             "boundaries": {"obstacles": )" +
         obstacles + R"(}, "probes": )" + probes + "}";
}

/// Writes the scene (and a cube.obj beside it) into a fresh folder; returns the scene file.
fs::path writeScene(const std::string& folder, const std::string& text) {
  const fs::path dir = tempDir(folder);
  writeTextAtomically(dir / "cube.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
  writeTextAtomically(dir / "scene.json", text);
  return dir / "scene.json";
}

Scene load(const std::string& text, const std::vector<std::string>& sets = {}) {
  return loadScene(writeScene("ok", text), sets);
}

/// The message of the InputError loading the scene throws, with the folder
/// replaced by "scene.json" ("" if it loads).
std::string loadError(const std::string& text, const std::vector<std::string>& sets = {}) {
  const fs::path file = writeScene("error", text);
  try {
    loadScene(file, sets);
  } catch (const InputError& error) {
    std::string message = error.what();
    const std::string prefix = file.string();
    if (message.rfind(prefix, 0) == 0) message = "scene.json" + message.substr(prefix.size());
    return message;
  }
  return "";
}

std::string obstacleWith(const std::string& extra, const std::string& name = "cube") {
  return R"({"name": ")" + name + R"(", "mesh": "cube.obj")" + (extra.empty() ? "" : ", " + extra) + "}";
}

const char* kKeyframes = R"("motion": {"keyframes": [
    {"t": 0.0, "translate": [0, 0, 0]},
    {"t": 1.0, "translate": [0.5, 0, 0], "rotate": [0, 0, 90]},
    {"t": 2.5, "rotate": [10, 20, 30]}]})";
const char* kPiston = R"("motion": {"piston": {"axis": [1, 0, 0], "stroke": 0.2, "period": 1.5, "ramp": 2}})";
} // namespace

TEST(SceneMotion, ParsesKeyframes) {
  const Scene scene = load(sceneText("[" + obstacleWith(kKeyframes) + "]"));
  ASSERT_EQ(scene.boundaries.obstacles.size(), 1u);
  const Obstacle& o = scene.boundaries.obstacles[0];
  ASSERT_TRUE(o.motion.has_value());
  EXPECT_FALSE(o.dynamic.has_value());
  EXPECT_FALSE(o.motion->piston.has_value());
  ASSERT_EQ(o.motion->keyframes.size(), 3u);
  EXPECT_EQ(o.motion->keyframes[0].t, 0.0);
  EXPECT_EQ(o.motion->keyframes[0].rotate, (Vec3{0, 0, 0}));
  EXPECT_EQ(o.motion->keyframes[1].translate, (Vec3{0.5, 0, 0}));
  EXPECT_EQ(o.motion->keyframes[1].rotate, (Vec3{0, 0, 90}));
  EXPECT_EQ(o.motion->keyframes[2].t, 2.5);
  EXPECT_EQ(o.motion->keyframes[2].translate, (Vec3{0, 0, 0}));  // default
  EXPECT_EQ(o.motion->keyframes[2].rotate, (Vec3{10, 20, 30}));
}

TEST(SceneMotion, ParsesPistonWithDefaults) {
  const Scene scene = load(sceneText("[" + obstacleWith(kPiston) + ", " +
                                     obstacleWith(R"("motion": {"piston": {"axis": [0, 2, 0]}})", "p2") + "]"));
  const Obstacle& o = scene.boundaries.obstacles[0];
  ASSERT_TRUE(o.motion && o.motion->piston);
  EXPECT_TRUE(o.motion->keyframes.empty());
  EXPECT_EQ(o.motion->piston->axis, (Vec3{1, 0, 0}));
  EXPECT_EQ(o.motion->piston->stroke, 0.2);
  EXPECT_EQ(o.motion->piston->period, 1.5);
  EXPECT_EQ(o.motion->piston->ramp, 2.0);
  const Piston& p2 = *scene.boundaries.obstacles[1].motion->piston;
  EXPECT_EQ(p2.axis, (Vec3{0, 2, 0}));  // kept as given
  EXPECT_EQ(p2.stroke, Piston{}.stroke);
  EXPECT_EQ(p2.period, Piston{}.period);
  EXPECT_EQ(p2.ramp, Piston{}.ramp);
}

TEST(SceneMotion, ParsesDynamicWithDensityOrMass) {
  const Scene scene = load(sceneText(
      "[" + obstacleWith(R"("dynamic": {"density": 500})", "a") + ", " +
      obstacleWith(R"("dynamic": {"mass": 2.5, "friction": 0.1, "restitution": 0.3})", "b") + ", " +
      obstacleWith("", "still") + "]"));
  const auto& obstacles = scene.boundaries.obstacles;
  ASSERT_TRUE(obstacles[0].dynamic.has_value());
  EXPECT_FALSE(obstacles[0].motion.has_value());
  EXPECT_EQ(obstacles[0].dynamic->density, 500.0);
  EXPECT_EQ(obstacles[0].dynamic->mass, 0.0);
  EXPECT_EQ(obstacles[0].dynamic->friction, 0.4);
  EXPECT_EQ(obstacles[0].dynamic->restitution, 0.0);
  ASSERT_TRUE(obstacles[1].dynamic.has_value());
  EXPECT_EQ(obstacles[1].dynamic->density, 0.0);
  EXPECT_EQ(obstacles[1].dynamic->mass, 2.5);
  EXPECT_EQ(obstacles[1].dynamic->friction, 0.1);
  EXPECT_EQ(obstacles[1].dynamic->restitution, 0.3);
  EXPECT_FALSE(obstacles[2].dynamic.has_value());
  EXPECT_FALSE(obstacles[2].motion.has_value());
}

TEST(SceneMotion, ParsesBodyAndVelocityProbes) {
  const Scene scene = load(sceneText(
      "[" + obstacleWith(R"("dynamic": {"density": 500})", "box") + ", " + obstacleWith(kPiston, "paddle") + "]",
      R"([{"name": "B", "type": "body", "obstacle": "box"},
          {"name": "P", "type": "body", "obstacle": "paddle"},
          {"name": "U", "type": "velocity", "at": [0.1, 0.2, 0.3]}])"));
  ASSERT_EQ(scene.probes.size(), 3u);
  EXPECT_EQ(scene.probes[0].type, "body");
  EXPECT_EQ(scene.probes[0].obstacle, "box");
  EXPECT_EQ(scene.probes[1].obstacle, "paddle");
  EXPECT_EQ(scene.probes[2].type, "velocity");
  EXPECT_EQ(scene.probes[2].at, (Vec3{0.1, 0.2, 0.3}));
}

TEST(SceneMotion, WriteReadRoundTrip) {
  const Scene first = load(sceneText(
      "[" + obstacleWith(kKeyframes, "k") + ", " + obstacleWith(kPiston, "p") + ", " +
          obstacleWith(R"("dynamic": {"density": 500})", "d") + ", " +
          obstacleWith(R"("dynamic": {"mass": 2.5, "friction": 0.1, "restitution": 0.3})", "m") + ", " +
          obstacleWith("", "s") + "]",
      R"([{"name": "B", "type": "body", "obstacle": "d"}, {"name": "U", "type": "velocity", "at": [0.1, 0.2, 0.3]}])"));
  const json written = sceneToJson(first);
  // Every default is present; unused alternatives are null.
  const json& obstacles = written["boundaries"]["obstacles"];
  EXPECT_EQ(obstacles[0]["motion"]["keyframes"][2]["translate"], json::array({0.0, 0.0, 0.0}));
  EXPECT_TRUE(obstacles[0]["motion"]["piston"].is_null());
  EXPECT_TRUE(obstacles[1]["motion"]["keyframes"].is_null());
  EXPECT_EQ(obstacles[1]["motion"]["piston"]["ramp"], 2.0);
  EXPECT_TRUE(obstacles[1]["dynamic"].is_null());
  EXPECT_EQ(obstacles[2]["dynamic"]["friction"], 0.4);
  EXPECT_TRUE(obstacles[2]["dynamic"]["mass"].is_null());
  EXPECT_TRUE(obstacles[3]["dynamic"]["density"].is_null());
  EXPECT_TRUE(obstacles[4]["motion"].is_null());
  EXPECT_TRUE(obstacles[4]["dynamic"].is_null());
  EXPECT_EQ(written["probes"][0]["obstacle"], "d");

  const fs::path file = tempDir("roundtrip") / "scene.json";
  writeTextAtomically(file, written.dump(2));
  const Scene second = readResolvedScene(file);
  EXPECT_EQ(sceneToJson(second), written);
  ASSERT_EQ(second.boundaries.obstacles.size(), 5u);
  for (std::size_t i = 0; i < 5; ++i) {
    SCOPED_TRACE(i);
    const Obstacle& a = first.boundaries.obstacles[i];
    const Obstacle& b = second.boundaries.obstacles[i];
    ASSERT_EQ(a.motion.has_value(), b.motion.has_value());
    ASSERT_EQ(a.dynamic.has_value(), b.dynamic.has_value());
    if (a.motion) {
      ASSERT_EQ(a.motion->keyframes.size(), b.motion->keyframes.size());
      for (std::size_t k = 0; k < a.motion->keyframes.size(); ++k) {
        EXPECT_EQ(a.motion->keyframes[k].t, b.motion->keyframes[k].t);
        EXPECT_EQ(a.motion->keyframes[k].translate, b.motion->keyframes[k].translate);
        EXPECT_EQ(a.motion->keyframes[k].rotate, b.motion->keyframes[k].rotate);
      }
      ASSERT_EQ(a.motion->piston.has_value(), b.motion->piston.has_value());
      if (a.motion->piston) {
        EXPECT_EQ(a.motion->piston->axis, b.motion->piston->axis);
        EXPECT_EQ(a.motion->piston->stroke, b.motion->piston->stroke);
        EXPECT_EQ(a.motion->piston->period, b.motion->piston->period);
        EXPECT_EQ(a.motion->piston->ramp, b.motion->piston->ramp);
      }
    }
    if (a.dynamic) {
      EXPECT_EQ(a.dynamic->density, b.dynamic->density);
      EXPECT_EQ(a.dynamic->mass, b.dynamic->mass);
      EXPECT_EQ(a.dynamic->friction, b.dynamic->friction);
      EXPECT_EQ(a.dynamic->restitution, b.dynamic->restitution);
    }
  }
  ASSERT_EQ(second.probes.size(), 2u);
  EXPECT_EQ(second.probes[0].type, "body");
  EXPECT_EQ(second.probes[0].obstacle, "d");
  EXPECT_EQ(second.probes[1].type, "velocity");
  EXPECT_EQ(second.probes[1].at, (Vec3{0.1, 0.2, 0.3}));
}

TEST(SceneMotion, SetOverridesReachTheNewKeys) {
  const std::string text = sceneText("[" + obstacleWith(R"("dynamic": {"density": 500})", "d") + ", " +
                                     obstacleWith(kKeyframes, "k") + ", " + obstacleWith("", "s") + "]");
  const Scene set = load(text, {"boundaries.obstacles[0].dynamic.density=800",
                                "boundaries.obstacles.0.dynamic.friction=0.2",
                                "boundaries.obstacles[1].motion.keyframes[2].t=3",
                                "boundaries.obstacles[1].motion.keyframes[1].translate=[0,1,0]"});
  EXPECT_EQ(set.boundaries.obstacles[0].dynamic->density, 800.0);
  EXPECT_EQ(set.boundaries.obstacles[0].dynamic->friction, 0.2);
  EXPECT_EQ(set.boundaries.obstacles[1].motion->keyframes[2].t, 3.0);
  EXPECT_EQ(set.boundaries.obstacles[1].motion->keyframes[1].translate, (Vec3{0, 1, 0}));

  // Switching density for mass; making a static obstacle dynamic; swapping a motion.
  const Scene swapped = load(text, {"boundaries.obstacles[0].dynamic.density=null",
                                    "boundaries.obstacles[0].dynamic.mass=3",
                                    R"(boundaries.obstacles[2].dynamic={"mass": 1})",
                                    "boundaries.obstacles[1].motion.keyframes=null",
                                    R"(boundaries.obstacles[1].motion.piston={"stroke": 0.3})"});
  EXPECT_EQ(swapped.boundaries.obstacles[0].dynamic->density, 0.0);
  EXPECT_EQ(swapped.boundaries.obstacles[0].dynamic->mass, 3.0);
  ASSERT_TRUE(swapped.boundaries.obstacles[2].dynamic.has_value());
  EXPECT_EQ(swapped.boundaries.obstacles[2].dynamic->mass, 1.0);
  ASSERT_TRUE(swapped.boundaries.obstacles[1].motion->piston.has_value());
  EXPECT_EQ(swapped.boundaries.obstacles[1].motion->piston->stroke, 0.3);

  // Overrides are validated like the file.
  EXPECT_EQ(loadError(text, {"boundaries.obstacles[0].dynamic.density=-1"}),
            "scene.json: boundaries.obstacles[0].dynamic.density: must be > 0 (got -1)");
  EXPECT_EQ(loadError(text, {"boundaries.obstacles[0].dynamic.mass=2"}),
            "scene.json: boundaries.obstacles[0].dynamic: give either \"density\" or \"mass\", not both");
  EXPECT_EQ(loadError(text, {"boundaries.obstacles[0].dynamic.densty=2"}),
            "--set boundaries.obstacles[0].dynamic.densty: unknown key 'boundaries.obstacles.0.dynamic.densty' "
            "(did you mean 'boundaries.obstacles.0.dynamic.density'?)");
  EXPECT_EQ(loadError(text, {"boundaries.obstacles[2].dynamic.density=800"}),
            "--set boundaries.obstacles[2].dynamic.density: boundaries.obstacles.2.dynamic is null; "
            "set the whole object instead");
}

TEST(SceneMotion, KeyframeErrors) {
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("motion": {"keyframes": [
                {"t": 0}, {"t": 2}, {"t": 1.5}]})") + "]")),
            "scene.json: boundaries.obstacles[0].motion.keyframes[2].t: keyframes must be in increasing time "
            "order (1.5 after 2)");
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("motion": {"keyframes": [{"t": 1}, {"t": 1}]})") + "]")),
            "scene.json: boundaries.obstacles[0].motion.keyframes[1].t: keyframes must be in increasing time "
            "order (1 after 1)");
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("motion": {"keyframes": []})") + "]")),
            "scene.json: boundaries.obstacles[0].motion.keyframes: must not be empty");
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("motion": {"keyframes": [{"translate": [1, 0, 0]}]})") + "]")),
            "scene.json: boundaries.obstacles[0].motion.keyframes[0].t: missing required key");
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("motion": {"keyframes": [{"t": 0, "rotate": [1, 0]}]})") + "]")),
            "scene.json: boundaries.obstacles[0].motion.keyframes[0].rotate: must be an array of 3 numbers (got [1,0])");
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("motion": {"keyframes": [{"t": 0, "translat": [1, 0, 0]}]})") + "]")),
            "scene.json: boundaries.obstacles[0].motion.keyframes[0].translat: unknown key (did you mean 'translate'?)");
}

TEST(SceneMotion, MotionAndPistonErrors) {
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("motion": {"keyframes": [{"t": 0}], "piston": {}})") + "]")),
            "scene.json: boundaries.obstacles[0].motion: give either \"keyframes\" or \"piston\", not both");
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("motion": {})") + "]")),
            "scene.json: boundaries.obstacles[0].motion: needs \"keyframes\" or \"piston\"");
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("motion": {"pistn": {}})") + "]")),
            "scene.json: boundaries.obstacles[0].motion.pistn: unknown key (did you mean 'piston'?)");
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("motion": {"piston": {"stroke": -0.1}})") + "]")),
            "scene.json: boundaries.obstacles[0].motion.piston.stroke: must be >= 0 (got -0.1)");
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("motion": {"piston": {"period": 0}})") + "]")),
            "scene.json: boundaries.obstacles[0].motion.piston.period: must be > 0 (got 0)");
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("motion": {"piston": {"ramp": -1}})") + "]")),
            "scene.json: boundaries.obstacles[0].motion.piston.ramp: must be >= 0 (got -1)");
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("motion": {"piston": {"axis": [0, 0, 0]}})") + "]")),
            "scene.json: boundaries.obstacles[0].motion.piston.axis: must not be the zero vector");
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("motion": {"piston": {"strok": 1}})") + "]")),
            "scene.json: boundaries.obstacles[0].motion.piston.strok: unknown key (did you mean 'stroke'?)");
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("motion": [1, 2])") + "]")),
            "scene.json: boundaries.obstacles[0].motion: must be an object (got [1,2])");
}

TEST(SceneMotion, DynamicErrors) {
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(std::string(kPiston) + R"(, "dynamic": {"mass": 1})") + "]")),
            "scene.json: boundaries.obstacles[0].dynamic: cannot be combined with \"motion\" (an obstacle moves "
            "as prescribed or is a rigid body, not both)");
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("dynamic": {"density": 500, "mass": 1})") + "]")),
            "scene.json: boundaries.obstacles[0].dynamic: give either \"density\" or \"mass\", not both");
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("dynamic": {"friction": 0.2})") + "]")),
            "scene.json: boundaries.obstacles[0].dynamic: needs \"density\" or \"mass\"");
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("dynamic": {"density": 0})") + "]")),
            "scene.json: boundaries.obstacles[0].dynamic.density: must be > 0 (got 0)");
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("dynamic": {"mass": -2})") + "]")),
            "scene.json: boundaries.obstacles[0].dynamic.mass: must be > 0 (got -2)");
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("dynamic": {"mass": 1, "friction": -0.1})") + "]")),
            "scene.json: boundaries.obstacles[0].dynamic.friction: must be >= 0 (got -0.1)");
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("dynamic": {"mass": 1, "restitution": 1.5})") + "]")),
            "scene.json: boundaries.obstacles[0].dynamic.restitution: must be in [0, 1] (got 1.5)");
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("dynamic": {"densty": 3})") + "]")),
            "scene.json: boundaries.obstacles[0].dynamic.densty: unknown key (did you mean 'density'?)");
  EXPECT_EQ(loadError(sceneText("[" + obstacleWith(R"("dynamc": {"mass": 1})") + "]")),
            "scene.json: boundaries.obstacles[0].dynamc: unknown key (did you mean 'dynamic'?)");
}

TEST(SceneMotion, ProbeErrors) {
  const std::string obstacles = "[" + obstacleWith(R"("dynamic": {"density": 500})", "cube") + ", " +
                                obstacleWith("", "wall") + "]";
  EXPECT_EQ(loadError(sceneText(obstacles, R"([{"name": "B", "type": "body"}])")),
            "scene.json: probes[0].obstacle: missing required key");
  EXPECT_EQ(loadError(sceneText(obstacles, R"([{"name": "B", "type": "body", "obstacle": "cub"}])")),
            "scene.json: probes[0].obstacle: no obstacle named \"cub\" (did you mean 'cube'?)");
  EXPECT_EQ(loadError(sceneText(obstacles, R"([{"name": "B", "type": "body", "obstacle": "wall"}])")),
            "scene.json: probes[0].obstacle: obstacle \"wall\" stands still; a body probe needs one with "
            "\"motion\" or \"dynamic\"");
  EXPECT_EQ(loadError(sceneText(obstacles, R"([{"name": "U", "type": "velocity"}])")),
            "scene.json: probes[0].at: missing required key");
  EXPECT_EQ(loadError(sceneText(obstacles, R"([{"name": "U", "type": "velocity", "at": [1, 2]}])")),
            "scene.json: probes[0].at: must be an array of 3 numbers (got [1,2])");
  EXPECT_EQ(loadError(sceneText(obstacles, R"([{"name": "U", "type": "velocty", "at": [1, 2, 3]}])")),
            "scene.json: probes[0].type: must be one of height, pressure, force, front, body, velocity (got "
            "\"velocty\") (did you mean 'velocity'?)");
  // A force probe still accepts a static obstacle.
  EXPECT_EQ(loadError(sceneText(obstacles, R"([{"name": "F", "type": "force", "obstacle": "wall"}])")), "");
}

TEST(SceneMotion, MeshSequencesAreCheckedFrameByFrame) {
  // A deforming sequence: "cube.####.obj", frames 1 to the last frame the bake reaches.
  const fs::path dir = tempDir("sequence");
  const auto errorOf = [&](const std::string& obstacles) -> std::string {
    std::string text = sceneText(obstacles);
    text.insert(text.size() - 1, R"(, "output": {"fps": 10, "end_time": 0.3})");
    writeTextAtomically(dir / "scene.json", text);
    try {
      loadScene(dir / "scene.json");
    } catch (const InputError& error) {
      std::string message = error.what();
      const std::string prefix = (dir / "scene.json").string();
      if (message.rfind(prefix, 0) == 0) message = "scene.json" + message.substr(prefix.size());
      return message;
    }
    return "";
  };
  const std::string sequence = R"({"name": "flex", "mesh": "cube.####.obj")";
  // Frames 1 and 2 of 3: the missing one is named, with its JSON path.
  const std::string cube = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
  for (const char* frame : {"cube.0001.obj", "cube.0002.obj"}) writeTextAtomically(dir / frame, cube);
  EXPECT_EQ(errorOf("[" + sequence + "}]"), "scene.json: boundaries.obstacles[0].mesh: frame 3 of the mesh sequence is missing: " +
                                               (dir / "cube.0003.obj").string() + " (the bake runs to frame 3)");
  writeTextAtomically(dir / "cube.0003.obj", cube);
  EXPECT_EQ(errorOf("[" + sequence + "}]"), "");
  const Scene scene = loadScene(dir / "scene.json");
  ASSERT_EQ(scene.boundaries.obstacles.size(), 1u);
  EXPECT_TRUE(scene.boundaries.obstacles[0].isSequence());
  EXPECT_EQ(scene.boundaries.obstacles[0].mesh, (dir / "cube.####.obj").string());
  // Written and read back, the pattern stays a pattern.
  const Scene again = parseScene(sceneToJson(scene), "again.json", dir);
  EXPECT_EQ(again.boundaries.obstacles[0].mesh, scene.boundaries.obstacles[0].mesh);
  // A sequence moves as its frames say, and keeps its triangles.
  EXPECT_EQ(errorOf("[" + sequence + ", " + kPiston + "}]"),
            "scene.json: boundaries.obstacles[0].motion: a deforming mesh sequence moves as its frames say: it takes "
            "no \"motion\" or \"dynamic\"");
  EXPECT_EQ(errorOf("[" + sequence + R"(, "dynamic": {"density": 500}})" + "]"),
            "scene.json: boundaries.obstacles[0].dynamic: a deforming mesh sequence moves as its frames say: it "
            "takes no \"motion\" or \"dynamic\"");
  EXPECT_EQ(errorOf("[" + sequence + R"(, "triangles": 100})" + "]"),
            "scene.json: boundaries.obstacles[0].triangles: a deforming mesh sequence is not simplified (every "
            "frame must keep the same triangles)");
}
