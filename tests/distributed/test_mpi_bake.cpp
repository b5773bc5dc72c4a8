// `mpirun -np N cascade bake` against one rank (label mpi): the SEED's dam break and
// bunny bakes on 1, 2 and 3 ranks (WCSPH and DFSPH), with a rank boundary through the
// obstacle and one through the emitter, and a floating body dropped into a pool, give
// bit-identical particle caches; a bake resumes on another rank count; a rank killed by
// SIGKILL stops the others within seconds and the checkpoint before it resumes; bad
// input is one line and exit 2.
#include "TestTempDir.h"
#include "bake/CascadeProcess.h"
#include "libsph/io/ParticleCache.h"

#include <gtest/gtest.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

using namespace cascade;
namespace fs = std::filesystem;

namespace {

using test::readLog;

const std::string kScenes = std::string(CASCADE_SOURCE_DIR) + "/scenes/";

struct Result {
  int status = -1;  ///< exit code
  std::string output;
};

Result run(const std::string& command, const fs::path& log) {
  const int status = std::system((command + " > '" + log.string() + "' 2>&1").c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, readLog(log)};
}

/// mpirun on this machine: as root (CI) it must be told so; 3 ranks on 2 cores oversubscribe.
std::string mpirun(int ranks) {
  return std::string("mpirun ") + (geteuid() == 0 ? "--allow-run-as-root " : "") + "--oversubscribe --bind-to none -np " +
         std::to_string(ranks) + " '" + test::cascadeBinary() + "' ";
}

Result bake(int ranks, const std::string& scene, const fs::path& out, const std::string& extra = "") {
  return run(mpirun(ranks) + "bake '" + kScenes + scene + "' -o '" + out.string() + "' --set size=seed " + extra,
             out.string() + ".log");
}

std::uint64_t checksum(const fs::path& out, int frame) {
  char name[32];
  std::snprintf(name, sizeof name, "particles.%04d.vdb", frame);
  return particleChecksum(readParticleFrame(out / "particles" / name));
}

std::size_t occurrences(const std::string& text, const std::string& part) {
  std::size_t count = 0;
  for (std::size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++count;
  return count;
}

/// `scene` baked on 1, 2 and 3 ranks into dir/np1, np2, np3; each bake succeeds and logs its rank count.
std::vector<fs::path> bakeOnOneTwoAndThreeRanks(const fs::path& dir, const std::string& scene,
                                                const std::string& extra = "") {
  std::vector<fs::path> outs;
  for (int ranks : {1, 2, 3}) {
    outs.push_back(dir / ("np" + std::to_string(ranks)));
    const Result result = bake(ranks, scene, outs.back(), extra);
    EXPECT_EQ(result.status, 0) << result.output;
    EXPECT_NE(result.output.find(std::to_string(ranks) + " MPI rank"), std::string::npos) << result.output;
  }
  return outs;
}

/// The 2- and 3-rank caches of `frames` have the 1-rank cache's checksum.
void expectEqualFrames(const std::vector<fs::path>& outs, const std::vector<int>& frames) {
  for (int frame : frames) {
    EXPECT_EQ(checksum(outs[1], frame), checksum(outs[0], frame)) << "frame " << frame;
    EXPECT_EQ(checksum(outs[2], frame), checksum(outs[0], frame)) << "frame " << frame;
  }
}

} // namespace

TEST(MpiBake, DamBreakOnOneTwoAndThreeRanksIsBitIdenticalEveryFrame) {
  const fs::path dir = test::freshTempDir("mpi_dambreak");
  const std::vector<fs::path> outs = bakeOnOneTwoAndThreeRanks(dir, "dambreak.json");
  ASSERT_FALSE(HasFailure());
  expectEqualFrames(outs, {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18});
  EXPECT_EQ(readParticleFrame(outs[2] / "particles" / "particles.0018.vdb").size(), 968u);
  // The probes too (front and column height), sampled from all ranks' particles.
  EXPECT_EQ(readLog(outs[1] / "probes.csv"), readLog(outs[0] / "probes.csv"));
  EXPECT_EQ(readLog(outs[2] / "probes.csv"), readLog(outs[0] / "probes.csv"));
}

TEST(MpiBake, BunnyWithRankBoundariesThroughTheObstacleAndTheEmitterEqualsOneRank) {
  const fs::path dir = test::freshTempDir("mpi_bunny");
  const std::string frames = "--frames 1-24";
  const Result one = bake(1, "bunny.json", dir / "np1", frames);
  ASSERT_EQ(one.status, 0) << one.output;
  const std::uint64_t reference = checksum(dir / "np1", 24);
  for (int ranks : {2, 3}) {
    const fs::path out = dir / ("np" + std::to_string(ranks));
    const Result result = bake(ranks, "bunny.json", out, frames);
    ASSERT_EQ(result.status, 0) << result.output;
    EXPECT_EQ(checksum(out, 24), reference) << ranks << " ranks";
  }
  // The bunny spans x = 0.11..0.43 m and the nozzle x = -1.43..-1.14 m; cuts placed by
  // hand stay put for the whole bake.
  for (const char* cut : {"0.27", "-1.28"}) {
    const fs::path out = dir / (std::string("cut") + cut);
    const Result result = bake(2, "bunny.json", out, frames + " --rank-cuts x=" + cut);
    ASSERT_EQ(result.status, 0) << result.output;
    EXPECT_NE(result.output.find(std::string("cut at ") + cut + " m"), std::string::npos) << result.output;
    EXPECT_EQ(occurrences(result.output, "rebalanced"), 0u) << result.output;
    EXPECT_EQ(checksum(out, 24), reference) << "cut at x = " << cut;
  }
}

// DFSPH's solves reduce over every rank: with sums that do not depend on the split
// (ReproducibleSum.h) its iterates, and so its particles, are bit-identical too.
TEST(MpiBake, DfsphOnOneTwoAndThreeRanksIsBitIdenticalAndResumesOnAnotherCount) {
  const fs::path dir = test::freshTempDir("mpi_dfsph");
  const std::string dfsph = "--set solver.type=dfsph";
  const std::vector<fs::path> outs = bakeOnOneTwoAndThreeRanks(dir, "dambreak.json", dfsph);
  ASSERT_FALSE(HasFailure());
  expectEqualFrames(outs, {1, 6, 12, 18});
  // The checkpoint holds the solver's warm starts of every rank's particles.
  const Result first = bake(2, "dambreak.json", dir / "split", dfsph + " --frames 1-9");
  ASSERT_EQ(first.status, 0) << first.output;
  const Result rest = bake(3, "dambreak.json", dir / "split", dfsph);
  ASSERT_EQ(rest.status, 0) << rest.output;
  EXPECT_NE(rest.output.find("resuming dambreak after frame 9"), std::string::npos) << rest.output;
  EXPECT_EQ(checksum(dir / "split", 18), checksum(outs[0], 18));
  // The bunny: mesh mirrors, an emitter, ranks that start with no water.
  const Result one = bake(1, "bunny.json", dir / "bunny1", dfsph + " --frames 1-15");
  ASSERT_EQ(one.status, 0) << one.output;
  const Result three = bake(3, "bunny.json", dir / "bunny3", dfsph + " --frames 1-15");
  ASSERT_EQ(three.status, 0) << three.output;
  EXPECT_EQ(checksum(dir / "bunny3", 15), checksum(dir / "bunny1", 15));
}

// A floating body (two-way coupling): the fluid's force and torque on it are summed by
// pre-rounding (ReactionSums.h), so every rank moves it with the bits one rank would,
// and the water it moves stays bit-identical too; the cuts at 2 and 3 ranks pass through
// the body. Its probes (pose, force, fluid velocity under it) are the same file.
TEST(MpiBake, AFloatingBodyOnOneTwoAndThreeRanksIsBitIdenticalAndResumesOnAnotherCount) {
  const fs::path dir = test::freshTempDir("mpi_body");
  const std::string shot = "--set output.end_time=0.6";
  const std::vector<fs::path> outs = bakeOnOneTwoAndThreeRanks(dir, "bunny_drop.json", shot);
  ASSERT_FALSE(HasFailure());
  expectEqualFrames(outs, {6, 12, 18});
  const std::string probes = readLog(outs[0] / "probes.csv");
  EXPECT_EQ(readLog(outs[1] / "probes.csv"), probes);
  EXPECT_EQ(readLog(outs[2] / "probes.csv"), probes);
  // The body did move: it fell into the pool (bunny_z, column 4, from 0.51 m) and the water pushed it.
  std::istringstream rows(probes);
  std::string header, row, line, last;
  std::getline(rows, header);
  ASSERT_EQ(header.rfind("t,bunny_x,bunny_y,bunny_z,", 0), 0u) << header;
  std::getline(rows, row);
  while (std::getline(rows, line))
    if (!line.empty()) last = line;
  const auto column = [](const std::string& line, int index) {
    std::istringstream cells(line);
    std::string cell;
    for (int k = 0; k <= index; ++k) std::getline(cells, cell, ',');
    return std::stod(cell);
  };
  EXPECT_LT(column(last, 3), column(row, 3) - 0.15) << last;
  EXPECT_GT(std::abs(column(last, 9)), 0.5) << last;  // F_bunny_z, N
  // The checkpoint holds the body's state: stopped on 2 ranks, resumed on 3.
  const Result first = bake(2, "bunny_drop.json", dir / "split", shot + " --frames 1-9");
  ASSERT_EQ(first.status, 0) << first.output;
  const Result rest = bake(3, "bunny_drop.json", dir / "split", shot);
  ASSERT_EQ(rest.status, 0) << rest.output;
  EXPECT_NE(rest.output.find("resuming bunny_drop after frame 9"), std::string::npos) << rest.output;
  EXPECT_EQ(checksum(dir / "split", 18), checksum(outs[0], 18));
  // WCSPH's coupling (SEED (11) samples on the body) as well.
  const Result wcsph1 = bake(1, "bunny_drop.json", dir / "w1", "--set output.end_time=0.4 --set solver.type=wcsph");
  ASSERT_EQ(wcsph1.status, 0) << wcsph1.output;
  const Result wcsph3 = bake(3, "bunny_drop.json", dir / "w3", "--set output.end_time=0.4 --set solver.type=wcsph");
  ASSERT_EQ(wcsph3.status, 0) << wcsph3.output;
  EXPECT_EQ(checksum(dir / "w3", 12), checksum(dir / "w1", 12));
  EXPECT_EQ(readLog(dir / "w3" / "probes.csv"), readLog(dir / "w1" / "probes.csv"));
}

TEST(MpiBake, ResumesOnAnotherRankCountBitIdentical) {
  const fs::path dir = test::freshTempDir("mpi_resume");
  const Result whole = bake(1, "dambreak.json", dir / "whole");
  ASSERT_EQ(whole.status, 0) << whole.output;
  const Result first = bake(2, "dambreak.json", dir / "split", "--frames 1-9");
  ASSERT_EQ(first.status, 0) << first.output;
  const Result rest = bake(3, "dambreak.json", dir / "split");
  ASSERT_EQ(rest.status, 0) << rest.output;
  EXPECT_NE(rest.output.find("resuming dambreak after frame 9"), std::string::npos) << rest.output;
  EXPECT_EQ(checksum(dir / "split", 18), checksum(dir / "whole", 18));
}

namespace {

/// The pids of the processes whose parent is `parent`.
std::vector<pid_t> childrenOf(pid_t parent) {
  std::vector<pid_t> children;
  for (const auto& entry : fs::directory_iterator("/proc")) {
    const std::string name = entry.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream stat(entry.path() / "stat");
    std::string text;
    std::getline(stat, text);
    const std::size_t close = text.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream rest(text.substr(close + 2));
    char state = 0;
    long ppid = 0;
    rest >> state >> ppid;
    if (ppid == parent) children.push_back(pid_t(std::stol(name)));
  }
  return children;
}

/// The value of `variable` in a process's environment ("" if absent).
std::string environmentOf(pid_t pid, const std::string& variable) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/environ", std::ios::binary);
  std::string entry;
  while (std::getline(in, entry, '\0'))
    if (entry.rfind(variable + "=", 0) == 0) return entry.substr(variable.size() + 1);
  return "";
}

} // namespace

TEST(MpiBake, ARankKilledStopsTheOthersWithinSecondsAndTheCheckpointResumes) {
  const fs::path dir = test::freshTempDir("mpi_kill");
  const std::string longer = "--set output.end_time=1.5";
  const Result reference = bake(1, "dambreak.json", dir / "reference", longer + " --frames 1-30");
  ASSERT_EQ(reference.status, 0) << reference.output;

  const fs::path out = dir / "killed";
  const pid_t launcher = fork();
  ASSERT_GE(launcher, 0);
  if (launcher == 0) {
    setpgid(0, 0);
    const std::string command = mpirun(2) + "bake '" + kScenes + "dambreak.json' -o '" + out.string() +
                                "' --set size=seed " + longer + " > '" + out.string() + ".log' 2>&1";
    execl("/bin/sh", "sh", "-c", ("exec " + command).c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  // Wait for the third frame, then kill rank 1 (a child of mpirun) by its pid.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!fs::exists(out / "particles" / "particles.0003.vdb") && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  pid_t rank1 = 0;
  for (pid_t child : childrenOf(launcher))
    if (environmentOf(child, "OMPI_COMM_WORLD_RANK") == "1") rank1 = child;
  if (rank1 == 0) kill(-launcher, SIGKILL);
  ASSERT_NE(rank1, 0) << "no rank 1 under mpirun " << launcher << "\n" << readLog(out.string() + ".log");
  ASSERT_EQ(kill(rank1, SIGKILL), 0);
  const auto killed = std::chrono::steady_clock::now();
  int status = 0;
  pid_t done = 0;
  while ((done = waitpid(launcher, &status, WNOHANG)) == 0 &&
         std::chrono::steady_clock::now() - killed < std::chrono::seconds(20))
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - killed).count();
  if (done == 0) {
    kill(-launcher, SIGKILL);
    waitpid(launcher, &status, 0);
  }
  ASSERT_EQ(done, launcher) << "mpirun still running " << seconds << " s after rank 1 died";
  EXPECT_LT(seconds, 10.0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) != 0) << readLog(out.string() + ".log");
  for (pid_t child : childrenOf(launcher)) ADD_FAILURE() << "rank process " << child << " left running";
  std::cout << "mpirun stopped " << seconds << " s after rank 1 was killed\n";

  // The checkpoint of the last whole frame resumes (on 2 ranks) to the reference's frame 30.
  const Result resumed = bake(2, "dambreak.json", out, longer + " --frames 1-30");
  ASSERT_EQ(resumed.status, 0) << resumed.output;
  EXPECT_NE(resumed.output.find("resuming dambreak after frame"), std::string::npos) << resumed.output;
  EXPECT_EQ(checksum(out, 30), checksum(dir / "reference", 30));
}

TEST(MpiBake, BadInputIsOneLineAndExitTwo) {
  const fs::path dir = test::freshTempDir("mpi_bad");
  // A tank 5 cm long at h = 2 cm: room for 2 slabs, not 3.
  const fs::path small = dir / "small.json";
  std::ofstream(small) << R"({"name": "small", "fluid": {"spacing": 0.01, "blocks": [{"min": [0, 0, 0], "max": [0.05, 0.04, 0.03]}]},
    "solver": {"type": "wcsph"}, "boundaries": {"tank": {"min": [0, 0, 0], "max": [0.05, 0.04, 0.1]}},
    "output": {"fps": 30, "end_time": 0.1}})";
  Result result = run(mpirun(3) + "bake '" + small.string() + "' -o '" + (dir / "small").string() + "'",
                      dir / "small.log");
  EXPECT_EQ(result.status, 2) << result.output;
  EXPECT_EQ(occurrences(result.output, "mpirun -np 3: the scene spans 0.05 m along x, room for 2 slabs"), 1u)
      << result.output;
  EXPECT_EQ(occurrences(result.output, "run at most 2 ranks"), 1u) << result.output;
  EXPECT_FALSE(fs::exists(dir / "small" / "particles" / "particles.0001.vdb"));

  result = run(mpirun(2) + "surface '" + (dir / "small").string() + "'", dir / "surface.log");
  EXPECT_EQ(result.status, 2) << result.output;
  EXPECT_EQ(occurrences(result.output, "only `cascade bake` and `cascade bench step` run over MPI ranks"), 1u)
      << result.output;
}
