#include "farm/JobScript.h"

#include "libsph/io/OutputLayout.h"

#include <sstream>

namespace cascade::farm {

std::string shellQuote(const std::string& text) {
  std::string quoted = "'";
  for (char c : text) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

namespace {

std::string roundDir(int round) { return "farm/jobs/round-" + std::to_string(round) + "/"; }

std::string frames(int first, int last) { return OutputLayout::pad(first) + "-" + OutputLayout::pad(last); }

std::string taskList(const std::vector<int>& tasks) {
  std::string list;
  std::size_t k = 0;
  while (k < tasks.size()) {
    if (!list.empty()) list += ",";
    // A run of three or more evenly spaced ids as A-B:S (sbatch's step syntax).
    std::size_t end = k;
    if (k + 1 < tasks.size()) {
      const int step = tasks[k + 1] - tasks[k];
      while (end + 1 < tasks.size() && tasks[end + 1] - tasks[end] == step) ++end;
    }
    if (end >= k + 2) {
      const int step = tasks[k + 1] - tasks[k];
      list += std::to_string(tasks[k]) + "-" + std::to_string(tasks[end]) + (step != 1 ? ":" + std::to_string(step) : "");
      k = end + 1;
    } else {
      list += std::to_string(tasks[k]);
      ++k;
    }
  }
  return list;
}

/// The header every job shares: options (`bake`: those of the bake and whitewater
/// chains, else those of the array tasks), then the check that this node sees OUT.
std::string header(const FarmRecord& record, const std::string& name, const std::string& log, bool bake,
                   const std::string& what, int ranks = 1) {
  const JobOptions& o = record.options;
  std::ostringstream s;
  s << "#!/bin/bash\n";
  s << "#SBATCH --job-name=" << name << "\n";
  s << "#SBATCH --output=" << record.out << "/farm/logs/" << log << "\n";
  if (!o.partition.empty()) s << "#SBATCH --partition=" << o.partition << "\n";
  if (!o.account.empty()) s << "#SBATCH --account=" << o.account << "\n";
  const std::string& time = bake ? o.bakeTime : o.taskTime;
  if (!time.empty()) s << "#SBATCH --time=" << time << "\n";
  if (ranks > 1) s << "#SBATCH --ntasks=" << ranks << "\n";  // an MPI bake: one task per rank
  s << "#SBATCH --cpus-per-task=" << (bake ? o.bakeCpus : o.taskCpus) << "\n";
  if (bake && !o.bakeMemory.empty()) s << "#SBATCH --mem=" << o.bakeMemory << "\n";
  s << "#SBATCH --requeue\n";
  s << "#SBATCH --kill-on-invalid-dep=yes\n";
  for (const std::string& extra : o.sbatch) s << "#SBATCH " << extra << "\n";
  s << "# " << what << "\n";
  s << "set -eu\n";
  s << "OUT=" << shellQuote(record.out) << "\n";
  s << "CASCADE=" << shellQuote(record.cascade) << "\n";
  for (const std::string& line : o.setup) s << line << "\n";
  s << "if [ \"$(cat \"$OUT/farm/token\" 2>/dev/null)\" != " << shellQuote(record.token) << " ]; then\n"
    << "  echo \"cascade farm: $(hostname) does not see the output folder $OUT that farm submit wrote: OUT must be "
       "on a filesystem every node mounts at the same path\" >&2\n"
    << "  exit 2\n"
    << "fi\n";
  return s.str();
}

} // namespace

std::string scriptName(int round, const PlannedJob& job) {
  return roundDir(round) + stageName(job.stage) + "." + frames(job.first, job.last) + ".sh";
}

std::string jobScript(const FarmRecord& record, int round, const PlannedJob& job) {
  const std::string stage = stageName(job.stage);
  const std::string name = record.scene + "." + stage + "." + frames(job.first, job.last);
  std::ostringstream what;
  std::ostringstream s;
  if (job.tasks.empty()) {
    what << "cascade farm round " << round << ": " << stage << " frames " << job.first << "-" << job.last << " of \""
         << record.scene << "\" (chunk " << job.chunkIndex + 1 << " of " << record.shot.chunkCount()
         << "), continuing from what the chunk before left";
    const int ranks = job.stage == Stage::Bake ? std::max(1, record.options.bakeRanks) : 1;
    s << header(record, name, stage + "." + frames(job.first, job.last) + ".%j.log", true, what.str(), ranks);
    const std::string range = std::to_string(job.first) + "-" + std::to_string(job.last);
    if (job.stage == Stage::Bake)
      s << "exec " << (ranks > 1 ? "srun --mpi=pmix " : "") << "\"$CASCADE\" bake \"$OUT/scene.json\" -o \"$OUT\" --frames "
        << range << "\n";
    else
      s << "exec \"$CASCADE\" whitewater \"$OUT\" --frames " << range << "\n";
    return s.str();
  }
  what << "cascade farm round " << round << ": " << stage << " frames " << job.first << "-" << job.last << " of \""
       << record.scene << "\", " << record.shot.taskFrames << " frame(s) per task; task k starts at frame " << job.first << " + k * "
       << record.shot.taskFrames;
  std::string text = header(record, name, stage + ".%A_%a.log", false, what.str());
  // The array option goes before the first non-#SBATCH line.
  std::vector<int> indices;
  for (int task : job.tasks) indices.push_back(record.shot.taskIndex(task));
  const std::string arrayLine = "#SBATCH --array=" + taskList(indices) + "\n";
  text.insert(text.find("# cascade farm"), arrayLine);
  s << text;
  s << "FIRST=$(( " << job.first << " + SLURM_ARRAY_TASK_ID * " << record.shot.taskFrames << " ))\n";
  s << "LAST=$(( FIRST + " << record.shot.taskFrames - 1 << " ))\n";
  s << "if [ \"$LAST\" -gt " << job.last << " ]; then LAST=" << job.last << "; fi\n";
  s << "exec \"$CASCADE\" " << stage << " \"$OUT\" --frames \"$FIRST-$LAST\"\n";
  return s.str();
}

std::string statusScriptName(int round) { return roundDir(round) + "status.sh"; }

std::string statusScript(const FarmRecord& record, int round) {
  std::ostringstream s;
  s << header(record, record.scene + ".status", "status.round-" + std::to_string(round) + ".%j.log", false,
              "cascade farm round " + std::to_string(round) +
                  ": once the round's jobs have ended, what is done (recorded in OUT/manifest.json)");
  s << "exec \"$CASCADE\" farm status \"$OUT\" --record\n";
  return s.str();
}

} // namespace cascade::farm
