/// @file FarmSubmit.h
/// @brief `cascade farm submit` and `cascade farm resume`: set a shot up in
///        OUT (the resolved scene, the farm record, the token every job checks),
///        plan the jobs its frames still need (FarmPlan.h), write their scripts
///        (JobScript.h) and submit them with sbatch, recording each id.
#pragma once

#include "farm/FarmRecord.h"
#include "libsph/scene/Scene.h"

#include <filesystem>
#include <ostream>
#include <string>

namespace cascade::farm {

struct SubmitSettings {
  std::filesystem::path out;
  int chunk = 10;
  int taskFrames = 1;
  JobOptions options;          ///< bakeCpus 0: the partition's cores per node
  std::string cascade;         ///< the program jobs run (default: this one)
  bool whitewater = true, render = true;
  bool dryRun = false;
};

/// Sets up OUT for `scene` and submits every job its frames need. Throws
/// InputError (exit 2) for no Slurm, an unknown partition, an OUT that cannot be
/// written or that has jobs queued or running.
void submitShot(const scene::Scene& scene, const SubmitSettings& settings, std::ostream& log);

/// Submits what is neither done nor queued or running; nothing when all is.
void resumeShot(const std::filesystem::path& out, bool dryRun, std::ostream& log);

/// `cascade farm cancel OUT`: scancel every job of the shot that is queued or
/// running (status jobs too); what is on disk stays, and `resume` continues.
void cancelShot(const std::filesystem::path& out, std::ostream& log);

/// `cascade farm status OUT`: prints each stage's frames by state (or JSON);
/// `record`: also marks in OUT/manifest.json the stages whose frames are all done.
void printStatus(const std::filesystem::path& out, bool json, bool record, std::ostream& print);

} // namespace cascade::farm
