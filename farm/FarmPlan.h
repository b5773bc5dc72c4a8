/// @file FarmPlan.h
/// @brief Which farm jobs a shot still needs, and what each waits for
///        (docs/farm.md): the job graph of `cascade farm submit|resume`.
///
/// The bake is sequential in time, so it runs as a chain of chunks of `chunk`
/// frames, each resuming from the checkpoint its predecessor left (afterok).
/// The whitewater stage, sequential too, is a second chain over the same
/// chunks; each of its jobs also waits for the bake chunk with its frames (for
/// the whole bake when its limits are automatic).
/// Surfacing and rendering are parallel over frames: per bake chunk one array
/// job each, whose tasks take `taskFrames` frames; a surface array waits only
/// for its own bake chunk, so meshing overlaps baking, and each render task for
/// the surface task with the same index (aftercorr). Tasks are aligned within
/// their chunk, so a resumed task covers the same frames as the one it replaces
/// (the stages skip frames that are done).
///
/// Pure: it reads per-frame states and returns jobs; FarmJobs.h submits them.
#pragma once

#include <string>
#include <vector>

namespace cascade::farm {

enum class Stage { Bake, Whitewater, Surface, Render };
inline constexpr Stage kStages[] = {Stage::Bake, Stage::Whitewater, Stage::Surface, Stage::Render};
/// "bake", "whitewater", "surface", "render".
const char* stageName(Stage stage);

/// The shot as the farm sees it.
struct ShotLayout {
  int frameCount = 0;
  int chunk = 10;        ///< frames per bake (and whitewater) job
  int taskFrames = 1;    ///< frames per surface or render array task
  bool whitewater = false;
  bool render = true;                  ///< false when the surface stage writes no mesh
  bool surfaceReadsWhitewater = false; ///< the surface stage's foam grid
  /// Whitewater with automatic limits: they come from the whole bake's statistics,
  /// so its chain waits for the last bake chunk (fixed limits pipeline with the bake).
  bool whitewaterNeedsWholeBake = false;

  int chunkCount() const { return chunk > 0 ? (frameCount + chunk - 1) / chunk : 0; }
  int chunkFirst(int index) const { return index * chunk + 1; }
  int chunkLast(int index) const;
  /// The first frame of the array task that holds `frame`.
  int taskFirst(int frame) const;
  int taskLast(int taskFirstFrame) const;
  /// The array task id of the task starting at `taskFirstFrame`: its index within its
  /// chunk (small, so no cluster's MaxArraySize limits the shot's length).
  int taskIndex(int taskFirstFrame) const;
  bool has(Stage stage) const;
};

/// One frame of one stage: its output is on disk, or a job that is still
/// pending or running covers it (`liveJob`: "123", or "123_45" for an array task).
struct FrameState {
  bool done = false;
  std::string liveJob;
  bool needsWork() const { return !done && liveJob.empty(); }
};

/// states[stage][frame - 1] for every stage the shot has (others may be empty).
struct ShotState {
  std::vector<FrameState> frames[4];
  std::vector<FrameState>& operator[](Stage stage) { return frames[int(stage)]; }
  const std::vector<FrameState>& operator[](Stage stage) const { return frames[int(stage)]; }
};

/// What a planned job waits for: another planned job (by index) or a live one.
struct Dependency {
  enum Kind { AfterOk, AfterCorresponding } kind = AfterOk;
  int planned = -1;      ///< index into the plan, or -1
  std::string live;      ///< a live job's id when planned < 0
};

struct PlannedJob {
  Stage stage = Stage::Bake;
  int chunkIndex = 0;
  int first = 0, last = 0;   ///< the chunk's frames (bake, whitewater: the job's --frames)
  std::vector<int> tasks;    ///< surface, render: the array tasks' first frames
  std::vector<Dependency> after;
};

/// The jobs that complete `state`: every frame that is neither done nor covered
/// by a live job gets one, with the dependencies above (on live jobs too).
std::vector<PlannedJob> planJobs(const ShotLayout& shot, const ShotState& state);

/// "afterok:1:2,aftercorr:3" from the ids of the plan's jobs (`ids[k]` for
/// planned job k) and the live ids; empty when the job waits for nothing.
std::string dependencyText(const std::vector<Dependency>& after, const std::vector<std::string>& ids);

} // namespace cascade::farm
