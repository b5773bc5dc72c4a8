// The render stage over an OUT directory (render/RenderStage.h) and the
// `cascade render` command's exit status.
#include "render/MeshPrimitives.h"
#include "render/RenderStage.h"

#include "libsph/Errors.h"
#include "libsph/io/ParticleCache.h"
#include "libsph/io/TriangleMesh.h"
#include "render/Image.h"

#include "TestTempDir.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <sstream>

using namespace cascade;
using namespace cascade::render;
namespace fs = std::filesystem;

namespace {

fs::path freshOut(const char* name) {
  const fs::path dir = cascade::test::freshTempDir(name);
  fs::create_directories(dir / "mesh");
  return dir;
}

RenderOptions smallOptions() {
  RenderOptions options;
  options.width = 160;
  options.height = 120;
  options.samples = 4;
  return options;
}

/// A z-up scene: tank solids, a camera and one light.
void writeScene(const fs::path& out) {
  std::ofstream(out / "scene.json") << R"({
    "name": "test",
    "boundaries": {"tank": {"min": [-1, -1, 0], "max": [1, 1, 1]}},
    "camera": {"position": [0.5, -4, 1.5], "target": [0, 0, 0.4], "up": [0, 0, 1], "fov": 40},
    "lights": [{"type": "directional", "direction": [0.3, 0.5, -1], "color": [1, 1, 1], "intensity": 1}]
  })";
  TriangleMesh solids = makeBox({-1, -1, -0.05f}, {1, 1, 0}, "tank");
  writeObj(out / "geometry" / "solids.obj", solids);
}

TriangleMesh blob(float z) { return makeIcosphere({0.1f, 0.2f, z}, 0.3f, 3); }

std::string withHeader(const std::string& header, const fs::path& obj) {
  std::ifstream in(obj);
  std::stringstream text;
  text << header << in.rdbuf();
  return text.str();
}

} // namespace

TEST(RenderStage, RendersEveryMeshAndReportsTheBrokenOneByName) {
  const fs::path out = freshOut("render_stage");
  writeScene(out);
  writeObj(out / "mesh" / "fluid.0001.obj", blob(0.3f));
  std::ofstream(out / "mesh" / "fluid.0002.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n";  // bad index
  writeObj(out / "mesh" / "fluid.0003.obj", blob(0.4f));
  RenderOptions options = smallOptions();
  options.meshUp = RenderOptions::MeshUp::Z;
  options.frames = parseFrameRange("1-4");  // frame 4 does not exist
  const RenderReport report = renderOutput(out, options);
  EXPECT_EQ(report.rendered, (std::vector<int>{1, 3}));
  ASSERT_EQ(report.errors.size(), 2u);
  EXPECT_NE(report.errors[0].find("fluid.0002.obj"), std::string::npos) << report.errors[0];
  EXPECT_NE(report.errors[1].find("fluid.0004.obj"), std::string::npos) << report.errors[1];
  EXPECT_TRUE(report.badInput);
  EXPECT_TRUE(fs::exists(out / "render" / "frame.0001.png"));
  EXPECT_FALSE(fs::exists(out / "render" / "frame.0002.png"));
  EXPECT_TRUE(fs::exists(out / "render" / "frame.0003.png"));
  try {
    report.throwIfFailed();
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("fluid.0002.obj"), std::string::npos);
  }
  const Image frame = readPng(out / "render" / "frame.0001.png");
  EXPECT_EQ(frame.width, 160);
  EXPECT_EQ(frame.height, 120);
  fs::remove_all(out);
}

TEST(RenderStage, EmptyMeshGivesAnEmptyFrameAndUpToDateFramesAreSkipped) {
  const fs::path out = freshOut("render_empty");
  writeObj(out / "mesh" / "fluid.0001.obj", TriangleMesh{});
  writeObj(out / "mesh" / "fluid.0002.obj", blob(0.3f));
  RenderOptions options = smallOptions();
  const RenderReport first = renderOutput(out, options);
  EXPECT_EQ(first.rendered, (std::vector<int>{1, 2}));
  EXPECT_TRUE(first.errors.empty());
  const Image empty = readPng(out / "render" / "frame.0001.png");
  const Image full = readPng(out / "render" / "frame.0002.png");
  EXPECT_NE(empty.rgba, full.rgba);

  const RenderReport second = renderOutput(out, options);  // nothing changed
  EXPECT_TRUE(second.rendered.empty());
  EXPECT_EQ(second.skipped, (std::vector<int>{1, 2}));
  options.width = 200;  // other settings: redraw
  EXPECT_EQ(renderOutput(out, options).rendered, (std::vector<int>{1, 2}));
  options.force = true;
  EXPECT_EQ(renderOutput(out, options).rendered, (std::vector<int>{1, 2}));
  fs::remove_all(out);
}

TEST(RenderStage, YUpMeshesAreDrawnUprightByTheirHeaderComment) {
  const fs::path out = freshOut("render_axes");
  writeScene(out);
  TriangleMesh mesh = blob(0.3f);
  writeObj(out / "mesh" / "fluid.0001.obj", mesh);
  RenderOptions options = smallOptions();
  renderOutput(out, options);
  const Image zUp = readPng(out / "render" / "frame.0001.png");

  // The same mesh written y-up ((x, y, z) -> (x, z, -y)) with "# up: y".
  for (auto& v : mesh.vertices) v = Eigen::Vector3f(v.x(), v.z(), -v.y());
  for (auto& n : mesh.normals) n = Eigen::Vector3f(n.x(), n.z(), -n.y());
  writeObj(out / "yup.obj", mesh);
  const std::string text = withHeader("# up: y\n", out / "yup.obj");
  std::ofstream(out / "mesh" / "fluid.0001.obj") << text;
  options.force = true;
  const RenderReport report = renderOutput(out, options);
  EXPECT_EQ(report.meshUp.substr(0, 1), "y") << report.meshUp;
  const Image yUp = readPng(out / "render" / "frame.0001.png");
  int differing = 0;
  for (std::size_t i = 0; i < zUp.rgba.size(); ++i) differing += std::abs(int(zUp.rgba[i]) - int(yUp.rgba[i])) > 2;
  EXPECT_LT(differing, 20) << "y-up mesh drawn differently from the z-up one";

  // Without the comment, the scene's tank box decides (the y-up blob would sit below the floor).
  writeObj(out / "mesh" / "fluid.0001.obj", mesh);
  EXPECT_EQ(renderOutput(out, options).meshUp.substr(0, 1), "y");
  fs::remove_all(out);
}

TEST(RenderStage, ParticlesContactSheetAndTurntable) {
  const fs::path out = freshOut("render_particles");
  for (int frame = 1; frame <= 3; ++frame) {
    ParticleFrame particles;
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j)
        for (int k = 0; k < 4; ++k) {
          particles.position.push_back(Vec3r(0.05f * i, 0.05f * j, 0.05f * k + 0.02f * frame));
          particles.velocity.push_back(Vec3r(0.2f * i, 0, -0.1f * frame));
          particles.id.push_back(ParticleId(particles.position.size()));
        }
    particles.spacing = 0.05f;
    writeParticleFrame(OutputLayout(out).particles(frame), particles);
  }
  RenderOptions options = smallOptions();
  options.particles = true;
  options.contactSheet = true;
  options.turntableViews = 4;
  const RenderReport report = renderOutput(out, options);
  EXPECT_EQ(report.rendered, (std::vector<int>{1, 2, 3}));
  EXPECT_TRUE(report.errors.empty()) << report.errors.front();
  const Image sheet = readPng(out / "render" / "contact_sheet.png");
  EXPECT_GT(sheet.width, 160);
  for (int view = 1; view <= 4; ++view)
    EXPECT_TRUE(fs::exists(out / "render" / ("turntable." + OutputLayout::pad(view) + ".png")));
  // View 1 is the camera itself: the same picture as frame 1.
  EXPECT_EQ(readPng(out / "render" / "turntable.0001.png").rgba, readPng(out / "render" / "frame.0001.png").rgba);
  EXPECT_NE(readPng(out / "render" / "turntable.0002.png").rgba, readPng(out / "render" / "frame.0001.png").rgba);
  fs::remove_all(out);
}

TEST(RenderStage, NoMeshesIsBadInput) {
  const fs::path out = freshOut("render_nothing");
  EXPECT_THROW(renderOutput(out, smallOptions()), InputError);
  EXPECT_THROW(renderOutput(out / "missing", smallOptions()), InputError);
  fs::remove_all(out);
}

TEST(RenderCommand, BrokenMeshExitsTwoNamingTheFileAndOtherFramesRender) {
  const fs::path program = fs::path(CASCADE_BINARY_DIR) / "cascade";
  if (!fs::exists(program)) GTEST_SKIP() << "cascade not built";
  const fs::path out = freshOut("render_command");
  writeObj(out / "mesh" / "fluid.0001.obj", blob(0.3f));
  std::ofstream(out / "mesh" / "fluid.0002.obj") << "v 0 0 0\nf 1 2 3\n";
  const fs::path log = out / "stderr.txt";
  const std::string command = program.string() + " render " + out.string() +
                              " --width 96 --height 64 --samples 1 > /dev/null 2> " + log.string();
  const int status = std::system(command.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 2);
  std::ifstream in(log);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  EXPECT_NE(text.find("fluid.0002.obj"), std::string::npos) << text;
  EXPECT_TRUE(fs::exists(out / "render" / "frame.0001.png"));
  EXPECT_FALSE(fs::exists(out / "render" / "frame.0002.png"));
  fs::remove_all(out);
}

// OSMesa is loaded when the first picture is drawn (render/OsMesaLibrary.h): without it,
// `cascade render` stops with one line naming the library it could not load and the
// Debian package, and draws nothing; every other subcommand starts without it.
TEST(RenderCommand, AMissingOsMesaIsOneLineNamingTheLibrary) {
  const fs::path program = fs::path(CASCADE_BINARY_DIR) / "cascade";
  if (!fs::exists(program)) GTEST_SKIP() << "cascade not built";
  const fs::path out = freshOut("render_no_osmesa");
  writeObj(out / "mesh" / "fluid.0001.obj", blob(0.3f));
  const fs::path log = out / "stderr.txt";
  const std::string missing = (out / "no_such_libOSMesa.so").string();
  const int status = std::system(("CASCADE_OSMESA_LIBRARY=" + missing + " " + program.string() + " render " +
                                  out.string() + " --width 96 --height 64 --samples 1 > /dev/null 2> " + log.string())
                                     .c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_NE(WEXITSTATUS(status), 0);
  std::ifstream in(log);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  EXPECT_NE(text.find(missing), std::string::npos) << text;
  EXPECT_NE(text.find("libosmesa6"), std::string::npos) << text;
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 1) << text;
  EXPECT_FALSE(fs::exists(out / "render" / "frame.0001.png"));
  // The program itself does not link OSMesa (nor LLVM).
  const fs::path maps = out / "maps.txt";
  ASSERT_EQ(std::system(("ldd " + program.string() + " > " + maps.string()).c_str()), 0);
  std::ifstream linked(maps);
  const std::string libraries((std::istreambuf_iterator<char>(linked)), {});
  EXPECT_EQ(libraries.find("libOSMesa"), std::string::npos) << libraries;
  EXPECT_EQ(libraries.find("libLLVM"), std::string::npos) << libraries;
  fs::remove_all(out);
}

TEST(RenderStage, BadSceneCameraIsBadInputNamingTheJsonPath) {
  const fs::path out = freshOut("render_badscene");
  writeObj(out / "mesh" / "fluid.0001.obj", blob(0.3f));
  std::ofstream(out / "scene.json") << R"({"camera": {"position": [0, 0], "target": [0, 0, 0]}})";
  try {
    renderOutput(out, smallOptions());
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("scene.json: camera.position"), std::string::npos) << error.what();
  }
  fs::remove_all(out);
}

// Moving solids: each frame draws its own geometry/solids.NNNN.obj. Three frames whose
// solids differ only in a box's height, rendered in one run, are each the same image
// as that frame rendered alone (the renderer keeps no stale solids between frames).
TEST(RenderStage, DrawsEachFramesOwnSolids) {
  const fs::path out = freshOut("render_moving_solids");
  writeScene(out);
  const float heights[3] = {0.2f, 0.5f, 0.8f};
  for (int f = 1; f <= 3; ++f) {
    writeObj(out / "mesh" / ("fluid.000" + std::to_string(f) + ".obj"), blob(0.3f));
    TriangleMesh solids = makeBox({-1, -1, -0.05f}, {1, 1, 0}, "tank");
    solids.append(makeBox({0.3f, -0.6f, heights[f - 1]}, {0.7f, -0.2f, heights[f - 1] + 0.3f}, "crate"));
    writeObj(out / "geometry" / ("solids.000" + std::to_string(f) + ".obj"), solids);
  }
  RenderOptions options = smallOptions();
  options.meshUp = RenderOptions::MeshUp::Z;
  ASSERT_EQ(renderOutput(out, options).rendered, (std::vector<int>{1, 2, 3}));
  std::vector<Image> together;
  for (int f = 1; f <= 3; ++f) together.push_back(readPng(out / "render" / ("frame.000" + std::to_string(f) + ".png")));
  EXPECT_NE(together[0].rgba, together[2].rgba);  // the crate moved
  for (int f = 1; f <= 3; ++f) {
    options.force = true;
    options.frames = parseFrameRange(std::to_string(f));
    ASSERT_EQ(renderOutput(out, options).rendered, (std::vector<int>{f}));
    EXPECT_EQ(readPng(out / "render" / ("frame.000" + std::to_string(f) + ".png")).rgba, together[f - 1].rgba)
        << "frame " << f;
  }
}
