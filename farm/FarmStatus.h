/// @file FarmStatus.h
/// @brief Where each frame of each stage of a farmed shot stands: done (its
///        files are in OUT), running or pending (the Slurm job that covers it,
///        as squeue reports it), failed (its job ended without it, with the
///        job's state and reason), or not submitted.
#pragma once

#include "farm/FarmRecord.h"
#include "farm/Slurm.h"

#include <nlohmann/json.hpp>

#include <map>
#include <string>
#include <vector>

namespace cascade::farm {

struct FrameStatus {
  enum Kind { Done, Running, Pending, Failed, Missing, Unknown } kind = Missing;
  std::string job;     ///< the Slurm id of the job (or array task) that covers it
  std::string detail;  ///< for a failed frame: "FAILED, exit 3", "CANCELLED (DependencyNeverSatisfied)", ...
  bool live() const { return kind == Running || kind == Pending; }  ///< its job is queued or running
};
const char* kindName(FrameStatus::Kind kind);

struct ShotStatus {
  std::vector<FrameStatus> frames[4];  ///< by Stage, frame - 1; empty for a stage the shot lacks
  bool schedulerAnswered = true;
  std::string schedulerError;
  const std::vector<FrameStatus>& operator[](Stage stage) const { return frames[int(stage)]; }
  bool complete(Stage stage) const;
};

/// Whether each stage's outputs for `frame` are in OUT (what the record says the stage writes).
bool frameDone(const FarmRecord& record, Stage stage, int frame);

/// The ids squeue is asked about: every recorded job's (arrays by their job id).
std::vector<std::string> recordedJobIds(const FarmRecord& record);

/// From OUT's files and `jobs` (queryJobs() of recordedJobIds()); `answered`
/// false when squeue could not be asked: frames not on disk are then Unknown.
ShotStatus shotStatus(const FarmRecord& record, const std::map<std::string, JobState>& jobs, bool answered,
                      const std::string& schedulerError = "");

/// The per-frame states planJobs() works from: done, or covered by a live job.
ShotState planningState(const FarmRecord& record, const ShotStatus& status);

/// "done 1-17, running 18, failed 19-20 (job 40_3: CANCELLED (DependencyNeverSatisfied))".
std::string statusLine(const std::vector<FrameStatus>& frames);
/// {"bake": {"done": [1, 2, ...], "running": [...], ..., "failed_jobs": {"40_3": "..."}}, ...}
nlohmann::json statusJson(const FarmRecord& record, const ShotStatus& status);

} // namespace cascade::farm
