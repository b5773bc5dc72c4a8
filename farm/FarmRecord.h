/// @file FarmRecord.h
/// @brief OUT/farm/farm.json: what `cascade farm submit` set up (the shot's
///        chunking, the job options, the stages' input hashes) and every job
///        each submit or resume round sent to Slurm, so that `farm status`
///        and `farm resume` work from OUT alone, on any machine that sees it.
#pragma once

#include "farm/FarmPlan.h"
#include "libsph/scene/Manifest.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace cascade::farm {

/// The sbatch settings every round's jobs get (docs/farm.md).
struct JobOptions {
  std::string partition, account;
  std::string bakeTime, taskTime;   ///< --time of bake/whitewater jobs and of surface/render tasks
  int bakeCpus = 1, taskCpus = 1;   ///< --cpus-per-task (of each bake rank)
  int bakeRanks = 1;                ///< MPI ranks of each bake job (srun --mpi=pmix; docs/distributed.md)
  std::string bakeMemory;           ///< --mem of bake and whitewater jobs (empty: the cluster's default)
  std::vector<std::string> sbatch;  ///< more #SBATCH options for every job
  std::vector<std::string> setup;   ///< shell lines every job runs before cascade
};

/// One job (or job array) sent to Slurm.
struct RecordedJob {
  Stage stage = Stage::Bake;
  std::string id;
  int first = 0, last = 0;   ///< its chunk's frames
  std::vector<int> tasks;    ///< array tasks' first frames (ShotLayout::taskIndex: their ids); empty: one job
  std::string script;        ///< relative to OUT
  std::string dependency;    ///< as given to sbatch
};

struct Round {
  int number = 0;
  std::string command;       ///< "submit" or "resume"
  std::string time;          ///< ISO 8601, UTC
  std::vector<RecordedJob> jobs;
  std::string statusJob;     ///< the job that records the stages done at the end
};

struct FarmRecord {
  std::string scene;         ///< the scene's name
  std::string token;         ///< OUT/farm/token's text: each job checks that it sees it
  std::string cascade;       ///< the program the jobs run
  std::string out;           ///< OUT, absolute
  ShotLayout shot;
  std::string surfaceOutputs = "both", meshFormat = "obj";
  bool whitewaterPly = false;
  scene::StageHashes hashes;
  JobOptions options;
  std::vector<Round> rounds;

  /// The latest job of `stage` that covers `frame`, and its Slurm id for that
  /// frame ("123", or "123_45" for the array task), or none.
  std::optional<std::pair<const RecordedJob*, std::string>> latestJob(Stage stage, int frame) const;
};

std::filesystem::path farmDir(const std::filesystem::path& out);
std::filesystem::path recordPath(const std::filesystem::path& out);

nlohmann::json toJson(const FarmRecord& record);
/// Throws InputError naming the file on anything that is not a farm record.
FarmRecord fromJson(const nlohmann::json& json, const std::string& file);

/// OUT/farm/farm.json; InputError when OUT was not set up by `farm submit`.
FarmRecord readRecord(const std::filesystem::path& out);
/// Written atomically.
void writeRecord(const FarmRecord& record);

} // namespace cascade::farm
