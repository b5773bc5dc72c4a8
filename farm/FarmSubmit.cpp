#include "farm/FarmSubmit.h"

#include "farm/FarmStatus.h"
#include "farm/JobScript.h"
#include "farm/Slurm.h"
#include "libsph/Errors.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/io/OutputLayout.h"
#include "libsph/scene/Manifest.h"
#include "libsph/scene/SceneJson.h"

#include <sys/stat.h>
#include <sys/vfs.h>

#include <chrono>
#include <ctime>
#include <random>
#include <set>

namespace cascade::farm {

namespace fs = std::filesystem;

namespace {

std::string utcNow() {
  const std::time_t now = std::time(nullptr);
  std::tm parts{};
  gmtime_r(&now, &parts);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &parts);
  return text;
}

std::string randomToken() {
  std::random_device device;
  std::mt19937_64 generator((std::uint64_t(device()) << 32) ^ device());
  return scene::hexHash(generator()) + scene::hexHash(generator());
}

/// The filesystem OUT is on, by name where Linux's statfs magic tells it.
std::string filesystemName(fs::path path, bool& shared) {
  struct statfs info {};
  shared = false;
  std::error_code error;
  while (!fs::exists(path, error) && path.has_parent_path() && path != path.parent_path()) path = path.parent_path();
  if (::statfs(path.c_str(), &info) != 0) return "unknown";
  switch (static_cast<unsigned long>(info.f_type)) {
  case 0x6969: shared = true; return "nfs";
  case 0x0BD00BD0: shared = true; return "lustre";
  case 0x47504653: shared = true; return "gpfs";
  case 0x19830326: shared = true; return "beegfs";
  case 0x00C36400: shared = true; return "ceph";
  case 0xFF534D42: shared = true; return "cifs";
  case 0xFE534D42: shared = true; return "smb2";
  case 0x65735546: shared = true; return "fuse";
  case 0xEF53: return "ext4";
  case 0x58465342: return "xfs";
  case 0x9123683E: return "btrfs";
  case 0x01021994: return "tmpfs";
  case 0x794C7630: return "overlayfs";
  default: return "unknown";
  }
}

/// What a stage made before with other inputs goes, so no stale frame counts as done.
void removeStaleOutputs(const OutputLayout& layout, Stage stage, std::ostream& log) {
  log << "farm: " << stageName(stage) << ": inputs changed since the last run; its old frames are removed\n";
  switch (stage) {
  case Stage::Bake: removeFrameFiles(layout.particlesDir(), "particles", "vdb"); break;
  case Stage::Whitewater:
    removeFrameFiles(layout.whitewaterDir(), "whitewater", "vdb");
    removeFrameFiles(layout.whitewaterDir(), "whitewater", "ply");
    break;
  case Stage::Surface:
    removeFrameFiles(layout.surfaceDir(), "surface", "vdb");
    removeFrameFiles(layout.meshDir(), "fluid", "obj");
    removeFrameFiles(layout.meshDir(), "fluid", "ply");
    break;
  case Stage::Render: removeFrameFiles(layout.renderDir(), "frame", "png"); break;
  }
}

const std::string& hashOf(const scene::StageHashes& hashes, Stage stage) {
  switch (stage) {
  case Stage::Bake: return hashes.bake;
  case Stage::Whitewater: return hashes.whitewater;
  case Stage::Surface: return hashes.surface;
  case Stage::Render: return hashes.render;
  }
  return hashes.bake;
}

/// The shot's status now; `required`: throw when squeue cannot answer.
ShotStatus currentStatus(const FarmRecord& record, bool required) {
  const std::vector<std::string> ids = recordedJobIds(record);
  try {
    return shotStatus(record, queryJobs(ids), true);
  } catch (const std::runtime_error& error) {
    if (required)
      throw InputError(std::string("farm: cannot ask Slurm about the shot's jobs (") + error.what() +
                       "); is the controller up, and SLURM_CONF set?");
    return shotStatus(record, {}, false, error.what());
  }
}

void requireSlurm() {
  if (findOnPath("sbatch").empty() || findOnPath("squeue").empty() || findOnPath("sinfo").empty())
    throw InputError("farm: Slurm's sbatch, squeue and sinfo are not on PATH: run on a submit host of the "
                     "cluster (Debian: apt-get install slurm-client), or --dry-run to print the job scripts");
}

/// A job script, written atomically and made executable; returns its path.
fs::path writeScript(const fs::path& path, const std::string& text) {
  writeTextAtomically(path, text);
  fs::permissions(path, fs::perms::owner_exec | fs::perms::group_exec, fs::perm_options::add);
  return path;
}

/// Writes the round's scripts and submits them in order (each after the jobs it
/// names), recording each id at once; then the status job after all of them.
void submitRound(FarmRecord& record, const std::string& command, const std::vector<PlannedJob>& plan, bool dryRun,
                 std::ostream& log) {
  const int number = int(record.rounds.size()) + 1;
  const fs::path out(record.out);
  std::vector<std::string> ids;
  for (const PlannedJob& job : plan)
    ids.push_back(dryRun ? "{" + std::string(stageName(job.stage)) + "." + std::to_string(job.first) + "-" +
                              std::to_string(job.last) + "}"
                        : std::string());
  if (!dryRun) {
    fs::create_directories(out / "farm" / "logs");
    fs::create_directories(out / "farm" / "jobs" / ("round-" + std::to_string(number)));
    Round round;
    round.number = number;
    round.command = command;
    round.time = utcNow();
    record.rounds.push_back(round);
  }
  int tasks[4] = {0, 0, 0, 0}, jobs[4] = {0, 0, 0, 0};
  for (std::size_t k = 0; k < plan.size(); ++k) {
    const PlannedJob& job = plan[k];
    const std::string name = scriptName(number, job);
    const std::string text = jobScript(record, number, job);
    const std::string dependency = dependencyText(job.after, ids);
    ++jobs[int(job.stage)];
    tasks[int(job.stage)] += job.tasks.empty() ? 1 : int(job.tasks.size());
    if (dryRun) {
      log << "# ---- " << name << (dependency.empty() ? "" : " (sbatch --dependency=" + dependency + ")") << "\n"
          << text;
      continue;
    }
    const fs::path script = writeScript(out / name, text);
    try {
      ids[k] = submitScript(script.string(), dependency);
    } catch (const std::runtime_error& error) {
      writeRecord(record);
      throw InputError(std::string(error.what()) + " (" + std::to_string(k) + " of " + std::to_string(plan.size()) +
                       " jobs were submitted; `cascade farm resume " + record.out + "` submits the rest)");
    }
    RecordedJob recorded{job.stage, ids[k], job.first, job.last, job.tasks, name, dependency};
    record.rounds.back().jobs.push_back(recorded);
    writeRecord(record);
    log << "farm: " << stageName(job.stage) << " frames " << job.first << "-" << job.last;
    if (!job.tasks.empty()) log << " (" << job.tasks.size() << " tasks)";
    log << ": job " << ids[k] << (dependency.empty() ? "" : " after " + dependency) << "\n";
  }
  // The status job: after every job of the round, whatever their ends.
  std::string after;
  for (const std::string& id : ids) after += ":" + id;
  if (dryRun) {
    log << "# ---- " << statusScriptName(number) << " (sbatch --dependency=afterany" << after << ")\n"
        << statusScript(record, number);
  } else {
    const fs::path script = writeScript(out / statusScriptName(number), statusScript(record, number));
    record.rounds.back().statusJob = submitScript(script.string(), "afterany" + after);
    writeRecord(record);
  }
  std::string summary;
  for (Stage stage : kStages)
    if (jobs[int(stage)] > 0)
      summary += (summary.empty() ? "" : ", ") + std::to_string(jobs[int(stage)]) + " " + stageName(stage) +
                 (jobs[int(stage)] == tasks[int(stage)] ? "" : " (" + std::to_string(tasks[int(stage)]) + " tasks)");
  log << "farm: round " << number << (dryRun ? " (dry run, nothing submitted): " : ": ") << summary << " jobs"
      << (dryRun ? "" : ", then job " + record.rounds.back().statusJob + " records what is done") << "\n";
}

/// The shot's record from the scene and the command line (no rounds yet).
FarmRecord recordFor(const scene::Scene& scene, const SubmitSettings& settings,
                     const std::vector<std::string>& meshHashes) {
  if (settings.chunk < 1) throw InputError("--chunk: must be >= 1 (got " + std::to_string(settings.chunk) + ")");
  if (settings.taskFrames < 1)
    throw InputError("--task-frames: must be >= 1 (got " + std::to_string(settings.taskFrames) + ")");
  if (settings.options.bakeCpus < 0 || settings.options.taskCpus < 1)
    throw InputError("--bake-cpus and --task-cpus: must be >= 1");
  if (settings.options.bakeRanks < 1)
    throw InputError("--ranks: must be >= 1 (got " + std::to_string(settings.options.bakeRanks) + ")");
  FarmRecord record;
  record.options = settings.options;
  record.out = fs::absolute(settings.out).lexically_normal().string();
  if (record.out.size() > 1 && record.out.back() == '/') record.out.pop_back();
  if (record.out.find_first_of(" \t\n\"'%") != std::string::npos)
    throw InputError("farm: " + record.out +
                     ": OUT must not contain white space, quotes or % (Slurm's #SBATCH --output line); give another -o");
  record.cascade = settings.cascade.empty() ? fs::canonical("/proc/self/exe").string() : settings.cascade;
  record.scene = scene.name;
  record.shot.frameCount = scene.output.frameCount();
  record.shot.chunk = settings.chunk;
  record.shot.taskFrames = std::min(settings.taskFrames, settings.chunk);
  record.shot.whitewater = scene.whitewater.has_value() && settings.whitewater;
  record.shot.surfaceReadsWhitewater = record.shot.whitewater && scene.surface.foamDensity;
  record.shot.whitewaterNeedsWholeBake = record.shot.whitewater && scene.whitewater->limits == "auto";
  record.shot.render = settings.render && scene.surface.outputs != "vdb";
  record.surfaceOutputs = scene.surface.outputs;
  record.meshFormat = scene.surface.meshFormat;
  record.whitewaterPly = scene.whitewater && scene.whitewater->ply;
  record.hashes = scene::stageInputHashes(scene, meshHashes, record.shot.whitewater);
  return record;
}

/// The partition the jobs go to (the cluster's default when none is named);
/// fills a bake's default core count from its nodes.
Partition choosePartition(FarmRecord& record) {
  requireSlurm();
  std::vector<Partition> partitions;
  try {
    partitions = listPartitions();
  } catch (const std::runtime_error& error) {
    throw InputError(std::string("farm: cannot reach the Slurm controller (") + error.what() +
                     "); is it up, and SLURM_CONF set?");
  }
  std::string names;
  const Partition* chosen = nullptr;
  for (const Partition& p : partitions) {
    names += (names.empty() ? "" : ", ") + p.name;
    if (record.options.partition.empty() ? p.isDefault : p.name == record.options.partition) chosen = &p;
  }
  if (!chosen) {
    if (record.options.partition.empty())
      throw InputError("farm: the cluster has no default partition: give --partition (one of: " + names + ")");
    throw InputError("--partition: the cluster has no partition '" + record.options.partition + "' (sinfo lists: " +
                     names + ")");
  }
  // Each bake rank gets its share of a node (one rank: the whole node).
  if (record.options.bakeCpus == 0)
    record.options.bakeCpus = std::max(1, chosen->cpusPerNode / std::max(1, record.options.bakeRanks));
  return *chosen;
}

/// OUT/farm with a new token (refused while an earlier submit's jobs are live),
/// the stale outputs of stages whose inputs changed removed, and OUT/scene.json.
void prepareOut(FarmRecord& record, const std::optional<FarmRecord>& previous, const Partition& partition,
                const scene::Scene& scene, const std::vector<std::string>& meshHashes, std::ostream& log) {
  if (previous) {
    const ShotStatus status = currentStatus(*previous, true);
    for (Stage stage : kStages)
      for (const FrameStatus& f : status.frames[int(stage)])
        if (f.live())
          throw InputError("farm: " + record.out + " has jobs queued or running (job " + f.job +
                           "): wait for them (cascade farm status), cancel them (cascade farm cancel), or give "
                           "another -o OUT");
    record.rounds = previous->rounds;  // the history stays; new rounds follow
  }
  try {
    fs::create_directories(farmDir(record.out));
    record.token = randomToken();
    writeTextAtomically(farmDir(record.out) / "token", record.token);
  } catch (const std::exception& failure) {
    throw InputError("farm: cannot write " + record.out + " (" + failure.what() +
                     "); give -o a folder on shared storage you can write");
  }
  bool shared = false;
  const std::string kind = filesystemName(fs::path(record.out), shared);
  log << "farm: OUT is " << record.out << " (" << kind << "); every job first checks that its node sees it\n";
  if (!shared && partition.nodes > 1)
    log << "farm: warning: partition " << partition.name << " has " << partition.nodes << " nodes and OUT is on a "
        << kind << " filesystem: jobs on nodes that do not mount it at the same path stop with exit 2\n";
  // Outputs made with other inputs go: the status counts files, so they must be this scene's.
  const OutputLayout layout(record.out);
  const nlohmann::json manifest = scene::readManifest(layout.manifest());
  for (Stage stage : kStages) {
    std::string before;
    if (previous) before = hashOf(previous->hashes, stage);
    else if (manifest["stages"].contains(stageName(stage)))
      before = manifest["stages"][stageName(stage)].value("input_hash", std::string());
    const std::string& now = hashOf(record.hashes, stage);
    if (!before.empty() && !now.empty() && before != now) removeStaleOutputs(layout, stage, log);
  }
  // The scene the jobs run, with every default filled in (the later stages read it too).
  scene::writeResolvedScene(scene, layout.scene(), meshHashes);
  writeRecord(record);
}

} // namespace

void submitShot(const scene::Scene& scene, const SubmitSettings& settings, std::ostream& log) {
  const std::vector<std::string> meshHashes = scene::meshContentHashes(scene);
  FarmRecord record = recordFor(scene, settings, meshHashes);
  if (settings.dryRun) {
    record.token = "(token)";
    if (record.options.bakeCpus == 0) record.options.bakeCpus = 1;
  } else {
    const Partition partition = choosePartition(record);
    std::optional<FarmRecord> previous;
    std::error_code error;
    if (fs::is_regular_file(recordPath(record.out), error)) previous = readRecord(record.out);
    prepareOut(record, previous, partition, scene, meshHashes, log);
  }
  const ShotStatus status = shotStatus(record, {}, true);
  const std::vector<PlannedJob> plan = planJobs(record.shot, planningState(record, status));
  log << "farm: " << scene.name << ", " << record.shot.frameCount << " frames in " << record.shot.chunkCount()
      << " chunks of " << record.shot.chunk << " (bake on "
      << (record.options.bakeRanks > 1 ? std::to_string(record.options.bakeRanks) + " MPI ranks x " : std::string())
      << record.options.bakeCpus << " core(s)), "
      << record.shot.taskFrames << " frame(s) per surface/render task\n";
  if (plan.empty()) {
    log << "farm: every frame of every stage is done in " << record.out << "; nothing to submit\n";
    return;
  }
  submitRound(record, "submit", plan, settings.dryRun, log);
}

void resumeShot(const fs::path& outDir, bool dryRun, std::ostream& log) {
  FarmRecord record = readRecord(fs::absolute(outDir).lexically_normal());
  const ShotStatus onDisk = shotStatus(record, {}, false);
  bool allDone = true;
  for (Stage stage : kStages) allDone = allDone && onDisk.complete(stage);
  if (allDone) {
    log << "farm: nothing to submit: every frame of every stage is done in " << record.out << "\n";
    return;
  }
  if (!dryRun) requireSlurm();
  const ShotStatus status = currentStatus(record, true);
  const std::vector<PlannedJob> plan = planJobs(record.shot, planningState(record, status));
  if (plan.empty()) {
    int live = 0;
    for (Stage stage : kStages)
      for (const FrameStatus& f : status.frames[int(stage)])
        live += f.live();
    log << "farm: nothing to submit: every frame is done" << (live ? " or queued (" + std::to_string(live) +
                                                                           " stage-frames running or pending)"
                                                                     : "")
        << "\n";
    return;
  }
  submitRound(record, "resume", plan, dryRun, log);
}

void cancelShot(const fs::path& outDir, std::ostream& log) {
  const FarmRecord record = readRecord(fs::absolute(outDir).lexically_normal());
  requireSlurm();
  std::vector<std::string> ids = recordedJobIds(record);
  for (const Round& round : record.rounds)
    if (!round.statusJob.empty()) ids.push_back(round.statusJob);
  std::map<std::string, JobState> states;
  try {
    states = queryJobs(ids);
  } catch (const std::runtime_error& error) {
    throw InputError(std::string("farm: cannot ask Slurm about the shot's jobs (") + error.what() + ")");
  }
  std::set<std::string> live;  // whole arrays: scancel 12 cancels every task of array 12
  for (const auto& [id, state] : states)
    if (state.live()) live.insert(id.substr(0, id.find('_')));
  if (live.empty()) {
    log << "farm: nothing of " << record.out << " is queued or running\n";
    return;
  }
  std::vector<std::string> argv{"scancel"};
  std::string list;
  for (const std::string& id : live) {
    argv.push_back(id);
    list += (list.empty() ? "" : " ") + id;
  }
  const CommandOutput output = runCommand(argv);
  if (output.status != 0)
    throw std::runtime_error("scancel: " + (output.err.empty() ? "exit " + std::to_string(output.status)
                                                                : output.err.substr(0, output.err.find('\n'))));
  log << "farm: cancelled " << live.size() << " job(s) of " << record.out << ": " << list
      << " (what is on disk stays; `cascade farm resume` continues)\n";
}

void printStatus(const fs::path& outDir, bool json, bool record, std::ostream& print) {
  const FarmRecord farm = readRecord(fs::absolute(outDir).lexically_normal());
  const ShotStatus status = currentStatus(farm, false);
  if (record) {
    const OutputLayout layout(farm.out);
    const nlohmann::json manifest = scene::readManifest(layout.manifest());
    for (Stage stage : kStages) {
      if (!farm.shot.has(stage) || !status.complete(stage) ||
          scene::stageIsCurrent(manifest, stageName(stage), hashOf(farm.hashes, stage)))
        continue;
      scene::recordStage(layout.manifest(), farm.scene, stageName(stage),
                         {{"done", true}, {"input_hash", hashOf(farm.hashes, stage)},
                          {"frames", farm.shot.frameCount}, {"farm", true}});
    }
  }
  if (json) {
    print << statusJson(farm, status).dump(2) << "\n";
    return;
  }
  print << "farm: " << farm.out << ": " << farm.scene << ", " << farm.shot.frameCount << " frames, "
        << farm.rounds.size() << " round(s)";
  if (!farm.rounds.empty()) print << ", the last (" << farm.rounds.back().command << ") at " << farm.rounds.back().time;
  print << "\n";
  if (!status.schedulerAnswered)
    print << "farm: squeue did not answer (" << status.schedulerError << "): frames not on disk are unknown\n";
  for (Stage stage : kStages) {
    if (!farm.shot.has(stage)) continue;
    char label[16];
    std::snprintf(label, sizeof label, "%-11s", stageName(stage));
    print << label << statusLine(status[stage]) << "\n";
  }
}

} // namespace cascade::farm
