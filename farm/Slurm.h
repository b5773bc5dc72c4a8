/// @file Slurm.h
/// @brief The Slurm client commands `cascade farm` uses (sbatch, squeue,
///        sinfo), run as child processes with their output captured.
///
/// Only the documented command-line interface of Slurm 22.05 is used
/// (sbatch --parsable, squeue -O with separators, sinfo -o), so any cluster
/// whose client commands are on PATH works; nothing links against libslurm.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace cascade::farm {

struct CommandOutput {
  int status = -1;        ///< exit status; 127 when the program could not be started
  std::string out, err;
};

/// Runs `argv` (argv[0] looked up on PATH) and waits for it.
CommandOutput runCommand(const std::vector<std::string>& argv);

/// The full path of `program` on PATH, or empty.
std::string findOnPath(const std::string& program);

/// A job's (or array task's) state as squeue reports it.
struct JobState {
  std::string state;      ///< PENDING, RUNNING, COMPLETED, FAILED, CANCELLED, TIMEOUT, ...
  std::string reason;     ///< squeue's reason, e.g. DependencyNeverSatisfied
  int exitCode = 0;       ///< the program's exit status (not the signal)
  bool live() const;      ///< pending, running, or about to (configuring, completing, requeued, suspended)
};

/// States by id ("123", or "123_45" per array task) of the jobs the controller
/// still knows (squeue --states=all; finished jobs are forgotten after the
/// cluster's MinJobAge). Throws std::runtime_error when squeue cannot answer.
std::map<std::string, JobState> queryJobs(const std::vector<std::string>& jobIds);

/// sbatch --parsable [--dependency=D] SCRIPT; returns the job id. Throws
/// std::runtime_error with sbatch's message when it refuses.
std::string submitScript(const std::string& script, const std::string& dependency);

/// A partition as sinfo lists it.
struct Partition {
  std::string name;
  bool isDefault = false;
  int cpusPerNode = 0;    ///< the smallest node's
  int nodes = 0;
};
/// The cluster's partitions; throws std::runtime_error with sinfo's message when
/// the controller cannot be reached.
std::vector<Partition> listPartitions();

} // namespace cascade::farm
