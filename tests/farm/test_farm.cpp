// `cascade farm` on a real one-node Slurm cluster (slurm-cluster.sh, started by
// the ctest fixture; SLURM_CONF points at it): a farmed shot equals a local
// `cascade run` file for file; a render task killed with scancel is named by
// `farm status` and completed by `farm resume`; a failed bake chunk cancels its
// dependants; bad input gives exit 2 and one line.
#include "bake/CascadeProcess.h"
#include "TestTempDir.h"
#include "farm/FarmRecord.h"
#include "farm/Slurm.h"
#include "distributed/MpiRuntime.h"
#include "libsph/io/OutputLayout.h"
#include "libsph/io/ParticleCache.h"
#include "libsph/scene/Manifest.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <openvdb/openvdb.h>

#include <chrono>
#include <filesystem>
#include <set>
#include <thread>

#include <unistd.h>

using namespace cascade;
using namespace cascade::test;
namespace fs = std::filesystem;

namespace {

const std::string kScenes = std::string(CASCADE_SOURCE_DIR) + "/scenes";

fs::path scratch(const std::string& name) {
  static const fs::path base = freshTempDir("farm");
  return base / name;
}

/// The seed bunny dropped for 1 s: 30 frames.
std::vector<std::string> bunnyScene() {
  return {kScenes + "/bunny.json", "--set", "size=seed", "--set", "output.end_time=1.0"};
}

std::vector<std::string> concat(std::vector<std::string> a, const std::vector<std::string>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

/// `cascade farm submit SCENE... -o OUT --chunk C --task-frames M --bake-cpus 1`
/// (one core each, so the arrays overlap the bake on the 2-core test node);
/// exit 0 or an EXPECT failure with its log. Returns the log's text.
std::string submitShot(const std::vector<std::string>& scene, const fs::path& out, int chunk, int taskFrames) {
  const fs::path log = out.string() + ".submit.log";
  const int status = run(concat(concat({"farm", "submit"}, scene),
                                {"-o", out.string(), "--chunk", std::to_string(chunk), "--task-frames",
                                 std::to_string(taskFrames), "--bake-cpus", "1"}),
                         log);
  EXPECT_EQ(status, 0) << readLog(log);
  return status == 0 ? readLog(log) : "";
}

/// `cascade farm status OUT --json`.
nlohmann::json statusOf(const fs::path& out) {
  const fs::path log = out.string() + ".status.json";
  EXPECT_EQ(run({"farm", "status", out.string(), "--json"}, log), 0) << readLog(log);
  return nlohmann::json::parse(readLog(log));
}

/// Waits until none of OUT's recorded jobs (and status jobs) is queued or running.
bool waitForShot(const fs::path& out, double seconds) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < until) {
    const farm::FarmRecord record = farm::readRecord(out);
    std::vector<std::string> ids;
    for (const farm::Round& round : record.rounds) {
      for (const farm::RecordedJob& job : round.jobs) ids.push_back(job.id);
      if (!round.statusJob.empty()) ids.push_back(round.statusJob);
    }
    bool live = false;
    for (const auto& [id, state] : farm::queryJobs(ids)) live = live || state.live();
    if (!live) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  return false;
}

std::vector<int> framesIn(const nlohmann::json& status, const std::string& stage, const std::string& state) {
  return status["stages"][stage][state].get<std::vector<int>>();
}

std::vector<int> range(int first, int last) {
  std::vector<int> frames;
  for (int f = first; f <= last; ++f) frames.push_back(f);
  return frames;
}

/// Every active voxel of the named grid equal in both files (and as many of them).
void expectSameGrid(const fs::path& a, const fs::path& b, const std::string& name) {
  openvdb::initialize();
  openvdb::io::File fa(a.string()), fb(b.string());
  fa.open();
  fb.open();
  const auto ga = openvdb::gridPtrCast<openvdb::FloatGrid>(fa.readGrid(name));
  const auto gb = openvdb::gridPtrCast<openvdb::FloatGrid>(fb.readGrid(name));
  ASSERT_TRUE(ga && gb) << a << " " << name;
  ASSERT_EQ(ga->activeVoxelCount(), gb->activeVoxelCount()) << a;
  const auto accessor = gb->getConstAccessor();
  std::size_t differ = 0;
  for (auto voxel = ga->cbeginValueOn(); voxel; ++voxel)
    differ += !accessor.isValueOn(voxel.getCoord()) || accessor.getValue(voxel.getCoord()) != *voxel;
  EXPECT_EQ(differ, 0u) << a;
}

} // namespace

TEST(Farm, AFarmedShotEqualsALocalRunFileForFile) {
  const fs::path local = scratch("local"), farmed = scratch("farmed");
  ASSERT_EQ(run(concat({"run"}, concat(bunnyScene(), {"-o", local.string()})), local.string() + ".log"), 0)
      << readLog(local.string() + ".log");
  const std::string submitted = submitShot(bunnyScene(), farmed, 10, 5);
  ASSERT_FALSE(submitted.empty());
  EXPECT_NE(submitted.find("bake frames 11-20: job"), std::string::npos) << submitted;
  ASSERT_TRUE(waitForShot(farmed, 900)) << "the shot did not finish in 15 minutes";

  const nlohmann::json status = statusOf(farmed);
  for (const char* stage : {"bake", "surface", "render"})
    EXPECT_EQ(framesIn(status, stage, "done"), range(1, 30)) << stage << "\n" << status.dump(1);
  const OutputLayout a(farmed), b(local);
  for (int f = 1; f <= 30; ++f) {
    EXPECT_EQ(particleChecksum(readParticleFrame(a.particles(f))), particleChecksum(readParticleFrame(b.particles(f))))
        << "frame " << f;
    EXPECT_EQ(readTextFile(a.mesh(f)), readTextFile(b.mesh(f))) << "frame " << f;
    expectSameGrid(a.surface(f), b.surface(f), "surface");
    EXPECT_EQ(readTextFile(a.render(f)), readTextFile(b.render(f))) << "frame " << f;
  }
  EXPECT_EQ(readTextFile(a.probes()), readTextFile(b.probes()));

  // The status job recorded the stages: a local run now skips every one, and a
  // resume has nothing to submit.
  const fs::path rerun = farmed.string() + ".run.log";
  ASSERT_EQ(run(concat({"run"}, concat(bunnyScene(), {"-o", farmed.string()})), rerun), 0) << readLog(rerun);
  for (const char* line : {"run: bake: scene unchanged", "run: surface: inputs unchanged, skipped",
                           "run: render: inputs unchanged, skipped"})
    EXPECT_NE(readLog(rerun).find(line), std::string::npos) << readLog(rerun);
  const fs::path resume = farmed.string() + ".resume.log";
  ASSERT_EQ(run({"farm", "resume", farmed.string()}, resume), 0) << readLog(resume);
  EXPECT_NE(readLog(resume).find("nothing to submit"), std::string::npos) << readLog(resume);
}

/// The line of `cascade inspect FILE` that starts with `key`.
std::string inspectLine(const fs::path& file, const std::string& key) {
  const fs::path log = file.string() + ".inspect.log";
  if (run({"inspect", file.string()}, log) != 0) return "(inspect failed: " + readLog(log) + ")";
  const std::string text = readLog(log);
  const std::size_t at = text.find("\n" + key);
  return at == std::string::npos ? "(no " + key + ")" : text.substr(at + 1, text.find('\n', at + 1) - at - 1);
}

TEST(Farm, AFarmedFloatingBodyShotWithWhitewaterEqualsALocalRun) {
  // The bunny floating in a pool: a rigid body whose state crosses the bake
  // chunks in the checkpoint, moving solids per frame, and the whitewater chain.
  const std::vector<std::string> scene{kScenes + "/bunny_drop.json", "--set", "size=seed", "--set",
                                       "output.end_time=0.6"};
  const fs::path local = scratch("drop_local"), farmed = scratch("drop_farmed");
  ASSERT_EQ(run(concat(concat({"run"}, scene), {"-o", local.string()}), local.string() + ".log"), 0)
      << readLog(local.string() + ".log");
  const std::string submitted = submitShot(scene, farmed, 6, 3);
  ASSERT_FALSE(submitted.empty());
  EXPECT_NE(submitted.find("whitewater frames 7-12: job"), std::string::npos) << submitted;
  ASSERT_TRUE(waitForShot(farmed, 900));
  const nlohmann::json status = statusOf(farmed);
  for (const char* stage : {"bake", "whitewater", "surface", "render"})
    EXPECT_EQ(framesIn(status, stage, "done"), range(1, 18)) << stage << "\n" << status.dump(1);
  const OutputLayout a(farmed), b(local);
  for (int f = 1; f <= 18; ++f) {
    EXPECT_EQ(particleChecksum(readParticleFrame(a.particles(f))), particleChecksum(readParticleFrame(b.particles(f))))
        << "frame " << f;
    EXPECT_EQ(readTextFile(a.solids(f)), readTextFile(b.solids(f))) << "frame " << f;
    const std::string checksum = inspectLine(a.whitewater(f), "checksum:");
    EXPECT_EQ(checksum.rfind("checksum:", 0), 0u) << checksum;
    EXPECT_EQ(checksum, inspectLine(b.whitewater(f), "checksum:")) << "frame " << f;
    EXPECT_EQ(readTextFile(a.mesh(f)), readTextFile(b.mesh(f))) << "frame " << f;
  }
  EXPECT_EQ(readTextFile(a.probes()), readTextFile(b.probes()));
}

TEST(Farm, AKilledRenderTaskIsNamedByStatusAndCompletedByResume) {
  // One render task of 15 frames per chunk, so the task cancelled below has
  // frames left when scancel reaches it.
  const fs::path out = scratch("killed");
  ASSERT_FALSE(submitShot(bunnyScene(), out, 15, 15).empty());
  // While it runs, a second submit into the same OUT is refused.
  const fs::path again = out.string() + ".again.log";
  EXPECT_EQ(run(concat({"farm", "submit"}, concat(bunnyScene(), {"-o", out.string()})), again), 2);
  EXPECT_NE(readLog(again).find("has jobs queued or running"), std::string::npos) << readLog(again);

  // Cancel the first chunk's render task once its first picture is on disk:
  // it is then running with 14 frames to go. (Polling squeue for RUNNING
  // instead lost the race on a loaded machine: a task seen late finished first.)
  const farm::FarmRecord record = farm::readRecord(out);
  std::string firstTask;
  int renderArrays = 0;
  for (const farm::RecordedJob& job : record.rounds[0].jobs)
    if (job.stage == farm::Stage::Render) {
      ++renderArrays;
      if (job.first == 1 && job.tasks == std::vector<int>{1}) firstTask = job.id + "_0";
    }
  ASSERT_EQ(renderArrays, 2);
  ASSERT_FALSE(firstTask.empty()) << "no render task of frames 1-15";
  std::string killed;
  const auto until = std::chrono::steady_clock::now() + std::chrono::minutes(10);
  while (killed.empty() && std::chrono::steady_clock::now() < until) {
    if (fs::exists(OutputLayout(out).render(1))) killed = firstTask;
    else std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_FALSE(killed.empty()) << "no render task ran";
  const farm::CommandOutput cancel = farm::runCommand({"scancel", killed});
  ASSERT_EQ(cancel.status, 0) << cancel.err;
  ASSERT_TRUE(waitForShot(out, 900));

  // The task's frames not on disk, and only those, are failed, named with the task.
  const nlohmann::json status = statusOf(out);
  std::vector<int> missing;
  for (int f = 1; f <= 30; ++f)
    if (!fs::exists(OutputLayout(out).render(f))) missing.push_back(f);
  ASSERT_FALSE(missing.empty()) << "the task " << killed << " finished before scancel reached it";
  EXPECT_EQ(framesIn(status, "render", "failed"), missing) << status.dump(1);
  EXPECT_EQ(framesIn(status, "render", "done").size() + missing.size(), 30u);
  EXPECT_NE(status["stages"]["render"]["failed_jobs"][killed].get<std::string>().find("CANCELLED"), std::string::npos)
      << status.dump(1);
  EXPECT_EQ(framesIn(status, "surface", "done"), range(1, 30));
  const fs::path text = out.string() + ".status.log";
  ASSERT_EQ(run({"farm", "status", out.string()}, text), 0);
  EXPECT_NE(readLog(text).find("(job " + killed + ": CANCELLED"), std::string::npos) << readLog(text);

  // Resume submits that one render task, a second resume nothing; then all is done.
  const fs::path resume = out.string() + ".resume.log";
  ASSERT_EQ(run({"farm", "resume", out.string()}, resume), 0) << readLog(resume);
  EXPECT_NE(readLog(resume).find("round 2: 1 render jobs"), std::string::npos) << readLog(resume);
  const fs::path second = out.string() + ".resume2.log";
  ASSERT_EQ(run({"farm", "resume", out.string()}, second), 0) << readLog(second);
  EXPECT_NE(readLog(second).find("nothing to submit"), std::string::npos) << readLog(second);
  ASSERT_TRUE(waitForShot(out, 600));
  EXPECT_EQ(framesIn(statusOf(out), "render", "done"), range(1, 30));
  const nlohmann::json manifest = scene::readManifest(OutputLayout(out).manifest());
  EXPECT_TRUE(manifest["stages"]["render"].value("done", false)) << manifest.dump(1);
}

TEST(Farm, AFailedBakeChunkCancelsItsDependantsAndStatusSaysSo) {
  // A dam break stepped at a fixed 1 ms: frame 1 bakes, frame 2 blows up (exit 3; at
  // t = 25 ms, and within frame 2 for any step from 0.8 to 1.2 ms).
  const std::vector<std::string> scene{kScenes + "/dambreak.json", "--set", "size=seed",
                                       "--set", "output.end_time=0.1", "--set", "solver.dt_min=0.001",
                                       "--set", "solver.dt_max=0.001"};
  const fs::path local = scratch("unstable_local");
  ASSERT_EQ(run(concat(concat({"bake"}, scene), {"-o", local.string()}), local.string() + ".log"), 3);
  ASSERT_TRUE(fs::exists(OutputLayout(local).particles(1)));
  ASSERT_FALSE(fs::exists(OutputLayout(local).particles(2)));

  const fs::path out = scratch("unstable");
  ASSERT_FALSE(submitShot(scene, out, 1, 1).empty());
  ASSERT_TRUE(waitForShot(out, 600));
  const nlohmann::json status = statusOf(out);
  for (const char* stage : {"bake", "surface", "render"}) {
    EXPECT_EQ(framesIn(status, stage, "done"), std::vector<int>{1}) << stage << "\n" << status.dump(1);
    EXPECT_EQ(framesIn(status, stage, "failed"), range(2, 6)) << stage << "\n" << status.dump(1);
  }
  const farm::FarmRecord record = farm::readRecord(out);
  std::map<int, std::string> bakeJob;
  for (const farm::RecordedJob& job : record.rounds[0].jobs)
    if (job.stage == farm::Stage::Bake) bakeJob[job.first] = job.id;
  const nlohmann::json& failed = status["stages"]["bake"]["failed_jobs"];
  EXPECT_NE(failed[bakeJob[2]].get<std::string>().find("FAILED, exit 3"), std::string::npos) << failed.dump(1);
  for (int f = 3; f <= 6; ++f)
    EXPECT_EQ(failed[bakeJob[f]].get<std::string>(), "CANCELLED (DependencyNeverSatisfied)") << failed.dump(1);
  for (const auto& [id, detail] : status["stages"]["render"]["failed_jobs"].items())
    EXPECT_EQ(detail.get<std::string>(), "CANCELLED (DependencyNeverSatisfied)") << id;
  // The log of the failed chunk names the particle.
  bool named = false;
  for (const auto& entry : fs::directory_iterator(out / "farm" / "logs"))
    if (entry.path().filename().string().rfind("bake.0002-0002.", 0) == 0)
      named = readLog(entry.path()).find("simulation unstable: particle") != std::string::npos;
  EXPECT_TRUE(named);
}

TEST(Farm, ACancelledShotResumesToTheSameParticlesAsOneBake) {
  const std::vector<std::string> scene{kScenes + "/dambreak.json", "--set", "size=seed", "--set",
                                       "output.end_time=0.2"};
  const fs::path local = scratch("cancel_local"), out = scratch("cancelled");
  ASSERT_EQ(run(concat(concat({"bake"}, scene), {"-o", local.string()}), local.string() + ".log"), 0);
  ASSERT_FALSE(submitShot(scene, out, 2, 2).empty());
  const fs::path cancel = out.string() + ".cancel.log";
  ASSERT_EQ(run({"farm", "cancel", out.string()}, cancel), 0) << readLog(cancel);
  EXPECT_NE(readLog(cancel).find("farm: cancelled "), std::string::npos) << readLog(cancel);
  ASSERT_TRUE(waitForShot(out, 300));
  nlohmann::json status = statusOf(out);
  for (const char* stage : {"bake", "surface", "render"}) {
    EXPECT_TRUE(status["stages"][stage]["running"].empty() && status["stages"][stage]["pending"].empty()) << stage;
    EXPECT_LT(framesIn(status, stage, "done").size(), 12u) << stage;  // the cancel came before the end
  }
  const fs::path second = out.string() + ".cancel2.log";
  ASSERT_EQ(run({"farm", "cancel", out.string()}, second), 0);
  EXPECT_NE(readLog(second).find("nothing of"), std::string::npos) << readLog(second);
  ASSERT_EQ(run({"farm", "resume", out.string()}, out.string() + ".resume.log"), 0)
      << readLog(out.string() + ".resume.log");
  ASSERT_TRUE(waitForShot(out, 600));
  status = statusOf(out);
  for (const char* stage : {"bake", "surface", "render"}) EXPECT_EQ(framesIn(status, stage, "done"), range(1, 12));
  for (int f = 1; f <= 12; ++f)
    EXPECT_EQ(particleChecksum(readParticleFrame(OutputLayout(out).particles(f))),
              particleChecksum(readParticleFrame(OutputLayout(local).particles(f))))
        << "frame " << f;
}

// `farm submit --ranks 2`: each bake chunk is an MPI job (srun --mpi=pmix -n 2), the
// second resuming from the first's checkpoint; the particles equal a local
// `mpirun -np 1` bake's bit for bit (docs/distributed.md).
TEST(Farm, AnMpiBakeOnTwoRanksPerChunkEqualsOneRankFrameForFrame) {
  if (!distributed::mpiBuilt()) GTEST_SKIP() << "built without MPI";
#ifdef CASCADE_MPI_LSAN_OPTIONS
  ::setenv("LSAN_OPTIONS", CASCADE_MPI_LSAN_OPTIONS, 1);  // Open MPI's own leaks (sanitizer build)
#endif
  const std::vector<std::string> scene{kScenes + "/dambreak.json", "--set", "size=seed", "--set",
                                       "output.end_time=0.1"};
  const fs::path local = scratch("mpi_local"), out = scratch("mpi_farmed");
  const std::string mpirun = std::string("mpirun ") + (geteuid() == 0 ? "--allow-run-as-root " : "") + "-np 1 '" +
                             CASCADE_BINARY_DIR + "/cascade' bake '" + scene[0] + "' -o '" + local.string() +
                             "' --set size=seed --set output.end_time=0.1 > '" + local.string() + ".log' 2>&1";
  ASSERT_EQ(std::system(mpirun.c_str()), 0) << readLog(local.string() + ".log");
  const fs::path log = out.string() + ".submit.log";
  ASSERT_EQ(run(concat(concat({"farm", "submit"}, scene),
                       {"-o", out.string(), "--chunk", "3", "--task-frames", "3", "--ranks", "2", "--bake-cpus", "1",
                        "--no-render"}),
                log),
            0)
      << readLog(log);
  EXPECT_NE(readLog(log).find("bake on 2 MPI ranks x 1 core(s)"), std::string::npos) << readLog(log);
  std::string script;  // the first chunk's bake job
  for (const auto& entry : fs::directory_iterator(out / "farm" / "jobs" / "round-1"))
    if (entry.path().filename().string().rfind("bake.", 0) == 0 && script.empty()) script = readLog(entry.path());
  EXPECT_NE(script.find("#SBATCH --ntasks=2\n"), std::string::npos) << script;
  EXPECT_NE(script.find("exec srun --mpi=pmix \"$CASCADE\" bake"), std::string::npos) << script;
  ASSERT_TRUE(waitForShot(out, 600));
  const nlohmann::json status = statusOf(out);
  EXPECT_EQ(framesIn(status, "bake", "done"), range(1, 6)) << status.dump();
  for (int f = 1; f <= 6; ++f)
    EXPECT_EQ(particleChecksum(readParticleFrame(OutputLayout(out).particles(f))),
              particleChecksum(readParticleFrame(OutputLayout(local).particles(f))))
        << "frame " << f;
}

TEST(Farm, BadInputGivesExit2AndOneLine) {
  const auto oneLine = [](const fs::path& log) {
    const std::string text = readLog(log);
    return !text.empty() && text.find('\n') == text.size() - 1;
  };
  const fs::path out = scratch("bad");
  // An unknown partition.
  fs::path log = out.string() + ".partition.log";
  EXPECT_EQ(run(concat({"farm", "submit"}, concat(bunnyScene(), {"-o", out.string(), "--partition", "nosuch"})), log), 2);
  EXPECT_TRUE(oneLine(log)) << readLog(log);
  EXPECT_NE(readLog(log).find("no partition 'nosuch' (sinfo lists: shots)"), std::string::npos) << readLog(log);
  EXPECT_FALSE(fs::exists(out));
  // No MPI rank at all.
  log = out.string() + ".ranks.log";
  EXPECT_EQ(run(concat({"farm", "submit"}, concat(bunnyScene(), {"-o", out.string(), "--ranks", "0"})), log), 2);
  EXPECT_TRUE(oneLine(log)) << readLog(log);
  EXPECT_NE(readLog(log).find("--ranks: must be >= 1 (got 0)"), std::string::npos) << readLog(log);
  EXPECT_FALSE(fs::exists(out));
  // An OUT that cannot be written: below a regular file.
  const fs::path file = scratch("a_file");
  writeTextAtomically(file, "x");
  log = out.string() + ".unwritable.log";
  EXPECT_EQ(run(concat({"farm", "submit"}, concat(bunnyScene(), {"-o", (file / "out").string()})), log), 2);
  EXPECT_TRUE(oneLine(log)) << readLog(log);
  EXPECT_NE(readLog(log).find("cannot write"), std::string::npos) << readLog(log);
  // No farm record.
  log = out.string() + ".status.log";
  EXPECT_EQ(run({"farm", "status", file.parent_path().string()}, log), 2);
  EXPECT_TRUE(oneLine(log)) << readLog(log);
  // No Slurm on PATH: submit refuses, --dry-run prints the scripts and writes nothing.
  const char* path = std::getenv("PATH");
  const std::string saved = path ? path : "";
  ::setenv("PATH", "/nonexistent", 1);
  log = out.string() + ".noslurm.log";
  const int noSlurm = run(concat({"farm", "submit"}, concat(bunnyScene(), {"-o", out.string()})), log);
  const fs::path dry = out.string() + ".dry.log";
  const int dryRun = run(concat({"farm", "submit"}, concat(bunnyScene(), {"-o", out.string(), "--dry-run"})), dry);
  ::setenv("PATH", saved.c_str(), 1);
  EXPECT_EQ(noSlurm, 2);
  EXPECT_TRUE(oneLine(log)) << readLog(log);
  EXPECT_NE(readLog(log).find("not on PATH"), std::string::npos) << readLog(log);
  EXPECT_EQ(dryRun, 0) << readLog(dry);
  EXPECT_NE(readLog(dry).find("#SBATCH --array=0-9\n"), std::string::npos) << readLog(dry);
  EXPECT_FALSE(fs::exists(out));
}
