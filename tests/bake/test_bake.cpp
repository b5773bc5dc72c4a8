// Resumable bakes: a bake killed with SIGKILL in the middle of a
// frame (or stopped with SIGINT) and started again with the same command
// ends with the same particles as one never stopped; run skips an unchanged
// bake; an unstable bake exits 3; bad scenes exit 2 and damage nothing.
#include "CascadeProcess.h"
#include "TestTempDir.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/io/OutputLayout.h"
#include "libsph/io/ParticleCache.h"
#include "libsph/io/TriangleMesh.h"
#include "libsph/scene/Manifest.h"

#include <gtest/gtest.h>

#include <gnu/libc-version.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>
#include <fcntl.h>

#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <chrono>
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

using namespace cascade;
using namespace cascade::test;
namespace fs = std::filesystem;

namespace {
const std::string kCascade = std::string(CASCADE_BINARY_DIR) + "/cascade";
const std::string kScenes = std::string(CASCADE_SOURCE_DIR) + "/scenes";

/// An output folder that does not exist yet, inside this process's scratch folder
/// (removed at exit; logs are written next to the output folders).
fs::path freshDir(const std::string& name) {
  static const fs::path base = cascade::test::freshTempDir("bake");
  const fs::path dir = base / name;
  fs::remove_all(dir);
  return dir;
}

/// A small dam break: about 1,000 particles, 12 frames of 1/60 s.
std::vector<std::string> bakeArgs(const fs::path& out) {
  return {"bake", kScenes + "/dambreak.json", "-o", out.string(), "--set", "size=seed",
          "--set", "output.end_time=0.2"};
}

std::uint64_t checksumOf(const fs::path& file) { return particleChecksum(readParticleFrame(file)); }

/// Waits until `file` exists (or the process ends); false on timeout.
bool waitForFile(const fs::path& file, pid_t pid, double seconds) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < until) {
    if (fs::exists(file)) return true;
    int status = 0;
    if (::waitpid(pid, &status, WNOHANG) == pid) return fs::exists(file);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return false;
}
} // namespace

class Bake : public ::testing::Test {
protected:
  static void SetUpTestSuite() {
    ASSERT_TRUE(fs::exists(kCascade)) << "build the cascade target first: " << kCascade;
    reference = new fs::path(freshDir("reference"));
    ASSERT_EQ(run(bakeArgs(*reference), *reference / "../bake_reference.log"), 0)
        << readLog(*reference / "../bake_reference.log");
  }
  static void TearDownTestSuite() {
    fs::remove_all(*reference);
    delete reference;
  }
  static fs::path* reference;
};
fs::path* Bake::reference = nullptr;

TEST_F(Bake, WritesOneCachePerFrameAndTheResolvedScene) {
  const OutputLayout layout(*reference);
  EXPECT_EQ(listFrames(layout.particlesDir(), "particles", "vdb").size(), 12u);
  EXPECT_TRUE(fs::exists(layout.scene()));
  EXPECT_TRUE(fs::exists(layout.probes()));
  EXPECT_TRUE(fs::exists(layout.root / "geometry" / "solids.obj"));
  const nlohmann::json manifest = scene::readManifest(layout.manifest());
  EXPECT_TRUE(manifest["stages"]["bake"]["done"].get<bool>());
  const ParticleFrame last = readParticleFrame(layout.particles(12));
  EXPECT_NEAR(last.time, 12.0 / 60.0, 1e-9);
  EXPECT_EQ(last.id.size(), last.size());
  EXPECT_EQ(last.density.size(), last.size());
  EXPECT_EQ(last.pressure.size(), last.size());
  // No temporary files left behind.
  for (const auto& entry : fs::recursive_directory_iterator(layout.root))
    EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos) << entry.path();
}

TEST_F(Bake, SigkillMidFrameThenResumeIsBitIdentical) {
  const fs::path out = freshDir("killed");
  const OutputLayout layout(out);
  const pid_t pid = spawn(bakeArgs(out), out.string() + ".log");
  // Kill in the middle of frame 5: frame 4 is complete, frame 5 is being stepped.
  ASSERT_TRUE(waitForFile(layout.particles(4), pid, 120)) << readLog(out.string() + ".log");
  std::this_thread::sleep_for(std::chrono::milliseconds(30));
  ::kill(pid, SIGKILL);
  EXPECT_EQ(waitFor(pid), 128 + SIGKILL);
  const std::size_t before = listFrames(layout.particlesDir(), "particles", "vdb").size();
  ASSERT_LT(before, 12u) << "the bake finished before it could be killed";

  const fs::path log = out.string() + ".resume.log";
  ASSERT_EQ(run(bakeArgs(out), log), 0) << readLog(log);
  EXPECT_NE(readLog(log).find("resuming"), std::string::npos) << readLog(log);
  for (int frame = 1; frame <= 12; ++frame)
    EXPECT_EQ(checksumOf(layout.particles(frame)), checksumOf(OutputLayout(*reference).particles(frame)))
        << "frame " << frame;
  EXPECT_EQ(readTextFile(layout.probes()), readTextFile(OutputLayout(*reference).probes()));
  fs::remove_all(out);
}

TEST_F(Bake, SigintStopsAfterAStepAndResumes) {
  const fs::path out = freshDir("interrupted");
  const OutputLayout layout(out);
  const pid_t pid = spawn(bakeArgs(out), out.string() + ".log");
  ASSERT_TRUE(waitForFile(layout.particles(2), pid, 120)) << readLog(out.string() + ".log");
  ::kill(pid, SIGINT);
  const int status = waitFor(pid);
  if (status == 1) {
    EXPECT_NE(readLog(out.string() + ".log").find("interrupted"), std::string::npos);
  } else {
    EXPECT_EQ(status, 0);  // finished before the signal arrived
  }
  ASSERT_EQ(run(bakeArgs(out), out.string() + ".resume.log"), 0);
  EXPECT_EQ(checksumOf(layout.particles(12)), checksumOf(OutputLayout(*reference).particles(12)));
  fs::remove_all(out);
}

TEST_F(Bake, RunSkipsAnUnchangedBake) {
  const fs::path out = freshDir("run");
  std::vector<std::string> args = bakeArgs(out);
  args[0] = "run";
  args.push_back("--no-surface");
  const fs::path log = out.string() + ".log";
  ASSERT_EQ(run(args, log), 0) << readLog(log);
  const auto written = fs::last_write_time(OutputLayout(out).particles(12));
  ASSERT_EQ(run(args, log), 0) << readLog(log);
  EXPECT_NE(readLog(log).find("bake: scene unchanged"), std::string::npos) << readLog(log);
  EXPECT_EQ(fs::last_write_time(OutputLayout(out).particles(12)), written);
  // A changed value re-bakes.
  args.push_back("--set");
  args.push_back("fluid.viscosity=0.001");
  ASSERT_EQ(run(args, log), 0) << readLog(log);
  EXPECT_EQ(readLog(log).find("bake: scene unchanged"), std::string::npos) << readLog(log);
  fs::remove_all(out);
}

TEST_F(Bake, RunResurfacesWithoutRebakingWhenOnlySurfaceSettingsChange) {
  const fs::path out = freshDir("run_surface");
  const OutputLayout layout(out);
  std::vector<std::string> args = bakeArgs(out);
  args[0] = "run";
  args.insert(args.end(), {"--no-render", "--set", "output.end_time=0.05"});  // 3 frames
  const fs::path log = out.string() + ".log";
  ASSERT_EQ(run(args, log), 0) << readLog(log);
  EXPECT_TRUE(fs::exists(layout.mesh(3, "obj")));
  const auto baked = fs::last_write_time(layout.particles(3));
  // Only the surface settings change: the bake is kept, the meshes are made again
  // as binary PLY (the OBJs go), and `cascade surface` alone reads the same settings.
  args.insert(args.end(), {"--set", "surface.mesh_format=ply"});
  ASSERT_EQ(run(args, log), 0) << readLog(log);
  EXPECT_NE(readLog(log).find("bake: scene unchanged"), std::string::npos) << readLog(log);
  EXPECT_EQ(fs::last_write_time(layout.particles(3)), baked);
  EXPECT_TRUE(fs::exists(layout.mesh(3, "ply")));
  EXPECT_FALSE(fs::exists(layout.mesh(3, "obj")));
  EXPECT_FALSE(readPly(layout.mesh(3, "ply")).velocities.empty());
  ASSERT_EQ(run(args, log), 0) << readLog(log);
  EXPECT_NE(readLog(log).find("surface: inputs unchanged, skipped"), std::string::npos) << readLog(log);
  // Only the VDB: no mesh is written.
  fs::remove_all(layout.meshDir());
  ASSERT_EQ(run({"surface", out.string(), "--no-mesh", "--force"}, log), 0) << readLog(log);
  EXPECT_FALSE(fs::exists(layout.meshDir() / "fluid.0003.ply"));
  EXPECT_TRUE(fs::exists(layout.surface(3)));
  fs::remove_all(out);
}

TEST_F(Bake, BadSceneExits2AndKeepsEarlierOutput) {
  const fs::path out = freshDir("bad");
  std::vector<std::string> args = bakeArgs(out);
  ASSERT_EQ(run(args, out.string() + ".log"), 0);
  const std::string sceneBefore = readTextFile(OutputLayout(out).scene());
  args.push_back("--set");
  args.push_back("fluid.spacing=-1");
  EXPECT_EQ(run(args, out.string() + ".log"), 2);
  const std::string message = readLog(out.string() + ".log");
  EXPECT_NE(message.find("dambreak.json: fluid.spacing: must be > 0 (got -1)"), std::string::npos) << message;
  EXPECT_EQ(readTextFile(OutputLayout(out).scene()), sceneBefore);
  args.back() = "fluid.spacng=0.1";
  EXPECT_EQ(run(args, out.string() + ".log"), 2);
  EXPECT_NE(readLog(out.string() + ".log").find("did you mean 'fluid.spacing'"), std::string::npos);
  fs::remove_all(out);
}

TEST_F(Bake, ABakeTooLargeForTheMachineIsRefusedBeforeAllocating) {
  // The dam break at 20 micrometres: about 10^12 particles. Refused in seconds with the
  // estimate, exit 2, before anything is written (an earlier bake's output stays).
  const fs::path out = freshDir("huge");
  std::vector<std::string> args = bakeArgs(out);
  ASSERT_EQ(run(args, out.string() + ".log"), 0);
  const std::string sceneBefore = readTextFile(OutputLayout(out).scene());
  args.push_back("--set");
  args.push_back("fluid.spacing=0.00002");
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(run(args, out.string() + ".log"), 2);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 20.0);
  const std::string message = readLog(out.string() + ".log");
  EXPECT_NE(message.find("bake: needs about "), std::string::npos) << message;
  EXPECT_NE(message.find(" GiB available (a coarser fluid.spacing, or --ignore-memory to try anyway)"), std::string::npos)
      << message;
  EXPECT_EQ(std::count(message.begin(), message.end(), '\n'), 1) << message;  // one line
  EXPECT_EQ(readTextFile(OutputLayout(out).scene()), sceneBefore);
  EXPECT_TRUE(fs::exists(OutputLayout(out).particles(12)));
  fs::remove_all(out);
}

TEST_F(Bake, SurfaceWritesAPlyWithVelocitiesThatInspectAndRenderRead) {
  const fs::path out = freshDir("ply");
  fs::copy(*reference, out, fs::copy_options::recursive);
  const OutputLayout layout(out);
  const fs::path log = out.string() + ".log";
  ASSERT_EQ(run({"surface", out.string(), "--frames", "12-12", "--mesh-format", "ply"}, log), 0) << readLog(log);
  EXPECT_TRUE(fs::exists(layout.mesh(12, "ply")));
  EXPECT_FALSE(fs::exists(layout.mesh(12, "obj")));
  // Vertex velocities are kernel-weighted means of particle velocities, so none is
  // faster than the fastest particle, and the splash moves: they are not all zero.
  const ParticleFrame particles = readParticleFrame(layout.particles(12));
  double fastest = 0;
  for (const Vec3r& v : particles.velocity) fastest = std::max(fastest, double(v.norm()));
  const TriangleMesh mesh = readPly(layout.mesh(12, "ply"));
  ASSERT_FALSE(mesh.vertices.empty());
  ASSERT_EQ(mesh.velocities.size(), mesh.vertices.size());
  double top = 0;
  for (const Eigen::Vector3f& v : mesh.velocities) top = std::max(top, double(v.norm()));
  EXPECT_LE(top, fastest * (1 + 1e-5));
  EXPECT_GT(top, 0.2 * fastest);
  ASSERT_EQ(run({"inspect", layout.mesh(12, "ply").string()}, log), 0) << readLog(log);
  EXPECT_NE(readLog(log).find("kind: PLY mesh"), std::string::npos) << readLog(log);
  EXPECT_NE(readLog(log).find("velocities: yes"), std::string::npos) << readLog(log);
  ASSERT_EQ(run({"inspect", layout.surface(12).string()}, log), 0) << readLog(log);
  EXPECT_NE(readLog(log).find("grid \"v\": type vec3s"), std::string::npos) << readLog(log);
  ASSERT_EQ(run({"render", out.string(), "--frames", "12-12"}, log), 0) << readLog(log);
  EXPECT_TRUE(fs::exists(layout.render(12)));
  // A mesh format Cascade does not write: one line, exit 2, nothing touched.
  ASSERT_EQ(run({"surface", out.string(), "--frames", "12-12", "--mesh-format", "fbx", "--force"}, log), 2);
  EXPECT_EQ(readLog(log), "--mesh-format: unknown mesh format 'fbx' (obj, ply)\n");
  EXPECT_TRUE(fs::exists(layout.mesh(12, "ply")));
  fs::remove_all(out);
}

// A shot folder (scene, assets, OUT) moved to another place, as to a farm node's mount:
// `cascade run` there skips every stage. OUT/scene.json and the manifest name the mesh
// relative to OUT with its content hash; OUT moved alone still surfaces and renders.
TEST(PortableOut, AMovedShotFolderRerunsWithEveryStageSkipped) {
  const fs::path base = freshDir("portable");
  const fs::path first = base / "shot", second = base / "moved" / "shot";
  fs::create_directories(first / "assets");
  fs::copy_file(kScenes + "/bunny.json", first / "bunny.json");
  fs::copy_file(kScenes + "/assets/bunny_res3.ply", first / "assets" / "bunny_res3.ply");
  const auto runArgs = [](const fs::path& shot) {
    return std::vector<std::string>{"run", (shot / "bunny.json").string(), "-o", (shot / "out").string(),
                                    "--set", "size=seed", "--set", "output.end_time=0.05"};
  };
  const fs::path log = base / "portable.log";
  ASSERT_EQ(run(runArgs(first), log), 0) << readLog(log);
  const OutputLayout layout(first / "out");
  const nlohmann::json written = nlohmann::json::parse(readTextFile(layout.scene()));
  const nlohmann::json& bunny = written["boundaries"]["obstacles"][0];
  EXPECT_EQ(bunny["mesh"], "../assets/bunny_res3.ply");
  EXPECT_EQ(bunny["mesh_hash"].get<std::string>().size(), 16u);
  const nlohmann::json asset = scene::readManifest(layout.manifest())["stages"]["bake"]["assets"][0];
  EXPECT_EQ(asset["mesh"], bunny["mesh"]);
  EXPECT_EQ(asset["hash"], bunny["mesh_hash"]);

  fs::create_directories(second.parent_path());
  fs::rename(first, second);
  ASSERT_EQ(run(runArgs(second), log), 0) << readLog(log);
  const std::string text = readLog(log);
  for (const char* skipped : {"bake: scene unchanged", "surface: inputs unchanged, skipped",
                              "render: inputs unchanged, skipped"})
    EXPECT_NE(text.find(skipped), std::string::npos) << skipped << "\n" << text;

  // A changed mesh (same path, other bytes) re-bakes.
  {
    std::ofstream append(second / "assets" / "bunny_res3.ply", std::ios::app);
    append << "\n";
  }
  const fs::path copy = base / "elsewhere" / "out";
  fs::create_directories(copy.parent_path());
  fs::copy(second / "out", copy, fs::copy_options::recursive);
  ASSERT_EQ(run(runArgs(second), log), 0) << readLog(log);
  EXPECT_EQ(readLog(log).find("bake: scene unchanged"), std::string::npos) << readLog(log);

  // OUT alone, without the scene's assets: the later stages read OUT only.
  ASSERT_EQ(run({"surface", copy.string(), "--force"}, log), 0) << readLog(log);
  ASSERT_EQ(run({"render", copy.string(), "--force"}, log), 0) << readLog(log);
  EXPECT_TRUE(fs::exists(OutputLayout(copy).render(1)));
  fs::remove_all(base);
}

// Found by fuzz_particle_cache: a point attribute page of size 0 makes Debian's OpenVDB
// (built with assertions) abort. While it reads, an abort is bad input: exit 2, naming
// the file (VdbReadScope); the same bytes under another name are read the same way.
TEST(Cli, ACorruptCacheThatAbortsOpenVdbIsBadInput) {
  const fs::path dir = freshDir("aborts");
  fs::create_directories(dir);
  const fs::path cache = dir / "particles.0001.vdb";
  fs::copy_file(fs::path(CASCADE_SOURCE_DIR) / "tests/fuzz/openvdb-aborts/page-size-zero.vdb", cache);
  const fs::path log = dir / "inspect.log";
  EXPECT_EQ(run({"inspect", cache.string()}, log), 2) << readLog(log);
  EXPECT_NE(readLog(log).find(cache.string() + ": corrupt OpenVDB file (OpenVDB failed reading it)"),
            std::string::npos)
      << readLog(log);
}

TEST(Cli, VersionNamesCascadeAndItsLibraries) {
  const fs::path log = freshDir("version").string() + ".log";
  EXPECT_EQ(run({"--version"}, log), 0);
  const std::string text = readLog(log);
  EXPECT_EQ(text.rfind("cascade " CASCADE_PROJECT_VERSION, 0), 0u) << text;
  for (const char* library : {"OpenVDB 10.", "oneTBB", "Eigen 3.", "CGAL 5.", "assimp 5.", "OSMesa", "libpng"})
    EXPECT_NE(text.find(library), std::string::npos) << library << " missing from\n" << text;
}

// The subcommands that surface restart once with glibc's huge-page tunable
// (tools/cascade/HugePages.h); `--version` goes the same way and says which heap it got.
// A caller's own tunables are kept, and a choice of the tunable is never overridden.
TEST(Cli, VersionReportsTheHeapTheSurfacingSubcommandsGet) {
  const fs::path log = freshDir("heap").string() + ".log";
  std::ifstream modes("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string mode;
  std::getline(modes, mode);
  int major = 0, minor = 0;
  std::sscanf(gnu_get_libc_version(), "%d.%d", &major, &minor);
  const bool available = (mode.find("[always]") != std::string::npos || mode.find("[madvise]") != std::string::npos) &&
                         (major > 2 || (major == 2 && minor >= 35));
  const char* saved = std::getenv("GLIBC_TUNABLES");
  const std::string savedValue = saved ? saved : "";
  auto heapLine = [&](const char* name, const char* value) {
    ::unsetenv("GLIBC_TUNABLES");
    if (name) ::setenv(name, value, 1);
    const int code = run({"--version"}, log);
    if (name) ::unsetenv(name);
    EXPECT_EQ(code, 0);
    const std::string text = readLog(log);
    const std::size_t at = text.find("  heap: ");
    return at == std::string::npos ? text : text.substr(at, text.find('\n', at) - at);
  };
  if (available) {
    EXPECT_EQ(heapLine(nullptr, nullptr), "  heap: transparent huge pages (GLIBC_TUNABLES=glibc.malloc.hugetlb=1)");
    EXPECT_EQ(heapLine("GLIBC_TUNABLES", "glibc.malloc.tcache_count=7"),
              "  heap: transparent huge pages (GLIBC_TUNABLES=glibc.malloc.tcache_count=7:glibc.malloc.hugetlb=1)");
    EXPECT_EQ(heapLine("GLIBC_TUNABLES", "glibc.malloc.hugetlb=0"), "  heap: 4 KiB pages (GLIBC_TUNABLES=glibc.malloc.hugetlb=0)");
    EXPECT_EQ(heapLine("CASCADE_HUGE_PAGES", "0"), "  heap: 4 KiB pages (CASCADE_HUGE_PAGES=0)");
  } else {
    EXPECT_EQ(heapLine(nullptr, nullptr).rfind("  heap: 4 KiB pages (", 0), 0u);
  }
  if (saved) ::setenv("GLIBC_TUNABLES", savedValue.c_str(), 1);
}

// docs/cli.md is the in-repo form of the interface users script against: every option
// `--help` prints, of the program and of each subcommand, is in it, under its subcommand's
// heading for subcommands.
TEST(Cli, EveryHelpTextIsInTheDocsAndConsistent) {
  const std::string docs = readTextFile(fs::path(CASCADE_SOURCE_DIR) / "docs" / "cli.md");
  const fs::path log = freshDir("help").string() + ".log";
  for (const std::string command :
       {"", "bake", "whitewater", "surface", "render", "run", "bench", "inspect", "schema", "farm", "farm submit",
        "farm status", "farm resume", "farm cancel"}) {
    std::vector<std::string> args;
    std::istringstream words(command);
    for (std::string word; words >> word;) args.push_back(word);
    args.push_back("--help");
    ASSERT_EQ(run(args, log), 0) << command;
    // The subcommand's section of the docs: from its heading to the next one.
    std::string section = docs;
    if (!command.empty()) {
      const std::size_t at = docs.find("### cascade " + command + "\n");
      ASSERT_NE(at, std::string::npos) << "no section for " << command;
      section = docs.substr(at, docs.find("\n### ", at + 1) - at);
    }
    // The subcommand's section holds its --help text as printed (indented as code).
    std::istringstream printed(readLog(log));
    std::string line, indented;
    while (std::getline(printed, line)) indented += (line.empty() ? "" : "    " + line) + "\n";
    while (indented.size() > 1 && indented.compare(indented.size() - 2, 2, "\n\n") == 0) indented.pop_back();
    if (!command.empty()) {
      EXPECT_NE(section.find(indented), std::string::npos)
          << "docs/cli.md's section differs from `cascade " << command << " --help`:\n" << indented;
    }
    std::istringstream help(readLog(log));
    int options = 0;
    while (std::getline(help, line)) {
      // Every description (from column 30) starts with a capital, as CLI11's own.
      if (line.size() > 30 && line.compare(28, 2, "  ") == 0 && std::isalpha(static_cast<unsigned char>(line[30]))) {
        EXPECT_TRUE(std::isupper(static_cast<unsigned char>(line[30]))) << "cascade " << command << ": " << line;
      }
      // Option lines: "  -o,--out TEXT   ..." or "  --frames TEXT  ...": each long name.
      std::istringstream words(line);
      std::string first;
      if (!(words >> first) || first.rfind("-", 0) != 0) continue;
      for (std::size_t at = first.find("--"); at != std::string::npos; at = first.find("--", at + 2)) {
        const std::string name = first.substr(at, first.find_first_of(", ", at) - at);
        ++options;
        EXPECT_NE(section.find(name), std::string::npos)
            << "cascade " << command << " " << name << " is not in docs/cli.md";
      }
    }
    EXPECT_GE(options, 1) << command;  // --help at least: the parse found the option lines
  }
}

TEST(Cli, AMistypedSubcommandIsNamedWithTheNearest) {
  const fs::path log = freshDir("mistyped").string() + ".log";
  EXPECT_EQ(run({"surfce", "out/x"}, log), 2);
  EXPECT_EQ(readLog(log), "cascade: unknown subcommand 'surfce' (did you mean 'surface'?) (see cascade --help)\n");
}

// The bench's study knobs are inputs too: an unknown choice is refused with one line and
// exit 2, never read as some default (CASCADE_ACCURACY_DENSITY read any value but
// "continuity" as summation), and before any case runs.
TEST(Cli, BenchAccuracyRefusesAnUnknownChoiceInItsEnvironment) {
  const fs::path log = freshDir("bench_choice").string() + ".log";
  const std::vector<std::pair<const char*, const char*>> cases = {
      {"CASCADE_ACCURACY_DENSITY", "sumation"}, {"CASCADE_ACCURACY_SLIP", "free-slip"},
      {"CASCADE_ACCURACY_CLAMP", "yes"}, {"CASCADE_ACCURACY_PRECONDITIONER", "multigrid"}};
  for (const auto& [name, value] : cases) {
    ::setenv(name, value, 1);
    const int code = run({"bench", "accuracy"}, log);
    ::unsetenv(name);
    EXPECT_EQ(code, 2) << name;
    const std::string text = readLog(log);
    EXPECT_EQ(text.rfind(std::string(name) + ": '" + value + "' is not one of ", 0), 0u) << text;
    EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 1) << text;
  }
}

TEST_F(Bake, UnstableBakeExits3NamingTheParticle) {
  const fs::path out = freshDir("unstable");
  std::vector<std::string> args = bakeArgs(out);
  // Far too large fixed steps for this stiffness: the column explodes.
  for (const char* set : {"solver.dt_min=0.004", "solver.dt_max=0.004", "solver.stiffness=1e6"}) {
    args.push_back("--set");
    args.push_back(set);
  }
  const fs::path log = out.string() + ".log";
  EXPECT_EQ(run(args, log), 3) << readLog(log);
  EXPECT_NE(readLog(log).find("particle"), std::string::npos) << readLog(log);
  const nlohmann::json manifest = scene::readManifest(OutputLayout(out).manifest());
  EXPECT_FALSE(manifest["stages"]["bake"]["done"].get<bool>());
  fs::remove_all(out);
}

// `cascade bench step --from OUT` times a shot where its bake stopped: the simulation is
// set up from OUT/scene.json and continued from OUT's checkpoint, and OUT is only read.
TEST_F(Bake, BenchStepContinuesAShotFromItsCheckpointAndLeavesItAsItWas) {
  const OutputLayout layout(*reference);
  const fs::path checkpoint = *reference / ".checkpoint" / "bake.ckpt";
  ASSERT_TRUE(fs::exists(checkpoint));
  const std::string before = readTextFile(checkpoint);
  const fs::path json = freshDir("bench_from").string() + ".json", log = json.string() + ".log";
  ASSERT_EQ(run({"bench", "step", "--from", reference->string(), "--steps", "3", "--json", json.string()}, log), 0)
      << readLog(log);
  const nlohmann::json table = nlohmann::json::parse(readTextFile(json));
  ASSERT_EQ(table["results"].size(), 1u);
  const nlohmann::json& row = table["results"][0];
  EXPECT_EQ(row["case"], "dambreak frame 12");
  EXPECT_EQ(row["solver"], nlohmann::json::parse(readTextFile(layout.scene()))["solver"]["type"]);
  EXPECT_EQ(row["n_fluid"].get<long long>(), static_cast<long long>(readParticleFrame(layout.particles(12)).size()));
  // Timed from the checkpoint's time (frame 12) after the two untimed steps, not from the start.
  const double t = row["t_s"].get<double>();
  EXPECT_GT(t, 12.0 / 60.0);
  EXPECT_LT(t, 12.0 / 60.0 + 0.01);
  EXPECT_GT(row["ms_per_step"].get<double>(), 0.0);
  EXPECT_EQ(readTextFile(checkpoint), before);

  // Refused with one line and exit 2: no checkpoint, or a checkpoint of another scene.
  const fs::path empty = freshDir("bench_from_empty");
  fs::create_directories(empty);
  fs::copy_file(layout.scene(), empty / "scene.json");
  EXPECT_EQ(run({"bench", "step", "--from", empty.string()}, log), 2);
  const std::string refused = readLog(log);
  EXPECT_NE(refused.find("has no bake checkpoint"), std::string::npos) << refused;
  EXPECT_EQ(std::count(refused.begin(), refused.end(), '\n'), 1) << refused;
  const fs::path edited = freshDir("bench_from_edited");
  fs::copy(*reference, edited, fs::copy_options::recursive);
  nlohmann::json scene = nlohmann::json::parse(readTextFile(edited / "scene.json"));
  scene["fluid"]["viscosity"] = scene["fluid"]["viscosity"].get<double>() * 2 + 1e-3;
  writeTextAtomically(edited / "scene.json", scene.dump(2));
  EXPECT_EQ(run({"bench", "step", "--from", edited.string()}, log), 2);
  EXPECT_NE(readLog(log).find("another version of its scene"), std::string::npos) << readLog(log);
  fs::remove_all(edited);
  fs::remove_all(empty);
}
