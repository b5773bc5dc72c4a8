/// @file JobScript.h
/// @brief The batch script of one farm job: #SBATCH options, the check that
///        the node sees OUT, and the one `cascade` stage command it runs.
///
/// Bake and whitewater jobs run `cascade bake|whitewater ... --frames A-B` over
/// their chunk (the stages resume from what the chunk before left); surface and
/// render array tasks take their first frame from SLURM_ARRAY_TASK_ID and run
/// up to `taskFrames` frames, stopping at their chunk's end.
#pragma once

#include "farm/FarmRecord.h"

#include <string>

namespace cascade::farm {

/// OUT/farm/jobs/round-N/<stage>.AAAA-BBBB.sh, relative to OUT.
std::string scriptName(int round, const PlannedJob& job);

/// The script's text. `record` gives OUT, the program, the token and the options.
std::string jobScript(const FarmRecord& record, int round, const PlannedJob& job);

/// The script of the job that runs `cascade farm status OUT --record` once a
/// round's jobs have ended, so the manifest says which stages are done.
std::string statusScript(const FarmRecord& record, int round);
std::string statusScriptName(int round);

/// Bash single-quoted.
std::string shellQuote(const std::string& text);

} // namespace cascade::farm
