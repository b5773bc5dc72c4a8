#include "farm/FarmRecord.h"

#include "libsph/Errors.h"
#include "libsph/io/AtomicFile.h"

namespace cascade::farm {

namespace fs = std::filesystem;
using nlohmann::json;

std::optional<std::pair<const RecordedJob*, std::string>> FarmRecord::latestJob(Stage stage, int frame) const {
  for (auto round = rounds.rbegin(); round != rounds.rend(); ++round)
    for (auto job = round->jobs.rbegin(); job != round->jobs.rend(); ++job) {
      if (job->stage != stage || frame < job->first || frame > job->last) continue;
      if (job->tasks.empty()) return std::make_pair(&*job, job->id);
      const int task = shot.taskFirst(frame);
      for (int t : job->tasks)
        if (t == task) return std::make_pair(&*job, job->id + "_" + std::to_string(shot.taskIndex(t)));
    }
  return std::nullopt;
}

fs::path farmDir(const fs::path& out) { return out / "farm"; }
fs::path recordPath(const fs::path& out) { return farmDir(out) / "farm.json"; }

namespace {
Stage stageFromName(const std::string& name, const std::string& file) {
  for (Stage stage : kStages)
    if (name == stageName(stage)) return stage;
  throw InputError(file + ": unknown stage '" + name + "'");
}
} // namespace

json toJson(const FarmRecord& r) {
  json rounds = json::array();
  for (const Round& round : r.rounds) {
    json jobs = json::array();
    for (const RecordedJob& job : round.jobs)
      jobs.push_back({{"stage", stageName(job.stage)}, {"id", job.id}, {"first", job.first}, {"last", job.last},
                      {"tasks", job.tasks}, {"script", job.script}, {"dependency", job.dependency}});
    rounds.push_back({{"round", round.number}, {"command", round.command}, {"time", round.time}, {"jobs", jobs},
                      {"status_job", round.statusJob}});
  }
  const JobOptions& o = r.options;
  return {{"farm_record", 1},
          {"scene", r.scene},
          {"token", r.token},
          {"cascade", r.cascade},
          {"out", r.out},
          {"frame_count", r.shot.frameCount},
          {"chunk", r.shot.chunk},
          {"task_frames", r.shot.taskFrames},
          {"whitewater", r.shot.whitewater},
          {"render", r.shot.render},
          {"surface_reads_whitewater", r.shot.surfaceReadsWhitewater},
          {"whitewater_needs_whole_bake", r.shot.whitewaterNeedsWholeBake},
          {"surface_outputs", r.surfaceOutputs},
          {"mesh_format", r.meshFormat},
          {"whitewater_ply", r.whitewaterPly},
          {"hashes", {{"bake", r.hashes.bake}, {"whitewater", r.hashes.whitewater}, {"surface", r.hashes.surface},
                      {"render", r.hashes.render}}},
          {"slurm", {{"partition", o.partition}, {"account", o.account}, {"bake_time", o.bakeTime},
                     {"task_time", o.taskTime}, {"bake_cpus", o.bakeCpus}, {"task_cpus", o.taskCpus}, {"bake_ranks", o.bakeRanks},
                     {"bake_memory", o.bakeMemory}, {"sbatch", o.sbatch}, {"setup", o.setup}}},
          {"rounds", rounds}};
}

FarmRecord fromJson(const json& j, const std::string& file) {
  if (!j.is_object() || j.value("farm_record", 0) != 1)
    throw InputError(file + ": not a cascade farm record");
  try {
    FarmRecord r;
    r.scene = j.at("scene").get<std::string>();
    r.token = j.at("token").get<std::string>();
    r.cascade = j.at("cascade").get<std::string>();
    r.out = j.at("out").get<std::string>();
    r.shot.frameCount = j.at("frame_count").get<int>();
    r.shot.chunk = j.at("chunk").get<int>();
    r.shot.taskFrames = j.at("task_frames").get<int>();
    r.shot.whitewater = j.at("whitewater").get<bool>();
    r.shot.render = j.at("render").get<bool>();
    r.shot.surfaceReadsWhitewater = j.at("surface_reads_whitewater").get<bool>();
    r.shot.whitewaterNeedsWholeBake = j.value("whitewater_needs_whole_bake", false);  // absent from records older than it
    if (r.shot.frameCount < 1 || r.shot.chunk < 1 || r.shot.taskFrames < 1)
      throw InputError(file + ": frame_count, chunk and task_frames must be >= 1");
    r.surfaceOutputs = j.at("surface_outputs").get<std::string>();
    r.meshFormat = j.at("mesh_format").get<std::string>();
    r.whitewaterPly = j.at("whitewater_ply").get<bool>();
    const json& h = j.at("hashes");
    r.hashes = {h.at("bake").get<std::string>(), h.at("whitewater").get<std::string>(),
                h.at("surface").get<std::string>(), h.at("render").get<std::string>()};
    const json& s = j.at("slurm");
    JobOptions& o = r.options;
    o.partition = s.at("partition").get<std::string>();
    o.account = s.at("account").get<std::string>();
    o.bakeTime = s.at("bake_time").get<std::string>();
    o.taskTime = s.at("task_time").get<std::string>();
    o.bakeCpus = s.at("bake_cpus").get<int>();
    o.taskCpus = s.at("task_cpus").get<int>();
    o.bakeRanks = s.value("bake_ranks", 1);  // records from before MPI bakes: one process
    o.bakeMemory = s.at("bake_memory").get<std::string>();
    o.sbatch = s.at("sbatch").get<std::vector<std::string>>();
    o.setup = s.at("setup").get<std::vector<std::string>>();
    for (const json& jr : j.at("rounds")) {
      Round round;
      round.number = jr.at("round").get<int>();
      round.command = jr.at("command").get<std::string>();
      round.time = jr.at("time").get<std::string>();
      round.statusJob = jr.at("status_job").get<std::string>();
      for (const json& jj : jr.at("jobs")) {
        RecordedJob job;
        job.stage = stageFromName(jj.at("stage").get<std::string>(), file);
        job.id = jj.at("id").get<std::string>();
        job.first = jj.at("first").get<int>();
        job.last = jj.at("last").get<int>();
        job.tasks = jj.at("tasks").get<std::vector<int>>();
        job.script = jj.at("script").get<std::string>();
        job.dependency = jj.at("dependency").get<std::string>();
        if (job.first < 1 || job.last < job.first || job.last > r.shot.frameCount)
          throw InputError(file + ": a job's frames " + std::to_string(job.first) + "-" + std::to_string(job.last) +
                           " are outside the shot");
        round.jobs.push_back(job);
      }
      r.rounds.push_back(round);
    }
    return r;
  } catch (const json::exception& error) {
    throw InputError(file + ": damaged farm record (" + std::string(error.what()) + ")");
  }
}

FarmRecord readRecord(const fs::path& out) {
  const fs::path file = recordPath(out);
  std::error_code error;
  if (!fs::is_regular_file(file, error))
    throw InputError(out.string() + ": no farm record (OUT/farm/farm.json); `cascade farm submit SCENE.json -o " +
                     out.string() + "` sets one up");
  json document;
  try {
    document = json::parse(readTextFile(file));
  } catch (const json::exception& failure) {
    throw InputError(file.string() + ": not valid JSON (" + failure.what() + ")");
  }
  return fromJson(document, file.string());
}

void writeRecord(const FarmRecord& record) {
  writeTextAtomically(recordPath(record.out), toJson(record).dump(2) + "\n");
}

} // namespace cascade::farm
