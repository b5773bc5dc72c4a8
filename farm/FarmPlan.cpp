#include "farm/FarmPlan.h"

#include <algorithm>

namespace cascade::farm {

const char* stageName(Stage stage) {
  switch (stage) {
  case Stage::Bake: return "bake";
  case Stage::Whitewater: return "whitewater";
  case Stage::Surface: return "surface";
  case Stage::Render: return "render";
  }
  return "?";
}

int ShotLayout::chunkLast(int index) const { return std::min((index + 1) * chunk, frameCount); }

int ShotLayout::taskFirst(int frame) const {
  const int start = chunkFirst((frame - 1) / chunk);
  return start + (frame - start) / taskFrames * taskFrames;
}

int ShotLayout::taskLast(int taskFirstFrame) const {
  return std::min(taskFirstFrame + taskFrames - 1, chunkLast((taskFirstFrame - 1) / chunk));
}

int ShotLayout::taskIndex(int taskFirstFrame) const {
  return (taskFirstFrame - chunkFirst((taskFirstFrame - 1) / chunk)) / taskFrames;
}

bool ShotLayout::has(Stage stage) const {
  switch (stage) {
  case Stage::Bake:
  case Stage::Surface: return true;
  case Stage::Whitewater: return whitewater;
  case Stage::Render: return render;
  }
  return false;
}

namespace {

/// The plan so far, and which planned job makes each frame of each stage.
class Planner {
public:
  Planner(const ShotLayout& shot, const ShotState& state) : shot_(shot), state_(state) {
    for (auto& frames : plannedFor_) frames.assign(std::size_t(shot.frameCount) + 1, -1);
  }

  bool needsWork(Stage stage, int frame) const { return state_[stage][std::size_t(frame - 1)].needsWork(); }

  bool anyNeedsWork(Stage stage, int first, int last) const {
    for (int f = first; f <= last; ++f)
      if (needsWork(stage, f)) return true;
    return false;
  }

  /// Every job (planned or live) that still has to make a frame of `stage` in [first, last].
  std::vector<Dependency> producers(Stage stage, int first, int last) const {
    std::vector<Dependency> found;
    for (int f = std::max(first, 1); f <= last; ++f) {
      Dependency d;
      if (const int planned = plannedFor_[int(stage)][std::size_t(f)]; planned >= 0) d.planned = planned;
      else if (const FrameState& s = state_[stage][std::size_t(f - 1)]; !s.done && !s.liveJob.empty()) d.live = s.liveJob;
      else continue;
      add(found, d);
    }
    return found;
  }

  static void add(std::vector<Dependency>& list, const Dependency& d) {
    for (const Dependency& e : list)
      if (e.kind == d.kind && e.planned == d.planned && e.live == d.live) return;
    list.push_back(d);
  }

  int push(PlannedJob job) {
    const int index = int(jobs_.size());
    if (job.tasks.empty()) {
      for (int f = job.first; f <= job.last; ++f) plannedFor_[int(job.stage)][std::size_t(f)] = index;
    } else {
      for (int task : job.tasks)
        for (int f = task; f <= shot_.taskLast(task); ++f) plannedFor_[int(job.stage)][std::size_t(f)] = index;
    }
    jobs_.push_back(std::move(job));
    return index;
  }

  /// A sequential stage: a chain of chunk jobs, each after the one before it and
  /// after `input`'s makers of the frames it reads (the frame before it and its
  /// own; with `wholeInput`, every frame of the shot).
  void planChain(Stage stage, const Stage* input, bool wholeInput) {
    for (int k = 0; k < shot_.chunkCount(); ++k) {
      const int first = shot_.chunkFirst(k), last = shot_.chunkLast(k);
      if (!anyNeedsWork(stage, first, last)) continue;
      PlannedJob job{stage, k, first, last, {}, {}};
      if (first > 1)
        for (const Dependency& d : producers(stage, first - 1, first - 1)) add(job.after, d);
      if (input)
        for (const Dependency& d : producers(*input, first - 1, wholeInput ? shot_.frameCount : last)) add(job.after, d);
      push(std::move(job));
    }
  }

  /// A parallel stage: per chunk, one array job over the tasks with work.
  std::vector<int> planArrays(Stage stage) {
    std::vector<int> byChunk(std::size_t(shot_.chunkCount()), -1);
    for (int k = 0; k < shot_.chunkCount(); ++k) {
      const int first = shot_.chunkFirst(k), last = shot_.chunkLast(k);
      PlannedJob job{stage, k, first, last, {}, {}};
      for (int task = first; task <= last; task += shot_.taskFrames)
        if (anyNeedsWork(stage, task, shot_.taskLast(task))) job.tasks.push_back(task);
      if (job.tasks.empty()) continue;
      if (stage == Stage::Surface) {
        for (const Dependency& d : producers(Stage::Bake, first, last)) add(job.after, d);
        if (shot_.surfaceReadsWhitewater)
          for (const Dependency& d : producers(Stage::Whitewater, first, last)) add(job.after, d);
      } else {  // render: after the surface task of the same index where both are planned now
        const int surface = surfaceByChunk_.empty() ? -1 : surfaceByChunk_[std::size_t(k)];
        if (surface >= 0 && jobs_[std::size_t(surface)].tasks == job.tasks) {
          add(job.after, Dependency{Dependency::AfterCorresponding, surface, {}});
        } else {
          for (int task : job.tasks)
            for (const Dependency& d : producers(Stage::Surface, task, shot_.taskLast(task))) add(job.after, d);
        }
        if (shot_.whitewater)
          for (const Dependency& d : producers(Stage::Whitewater, first, last)) add(job.after, d);
      }
      byChunk[std::size_t(k)] = push(std::move(job));
    }
    if (stage == Stage::Surface) surfaceByChunk_ = byChunk;
    return byChunk;
  }

  std::vector<PlannedJob> take() { return std::move(jobs_); }

private:
  const ShotLayout& shot_;
  const ShotState& state_;
  std::vector<int> plannedFor_[4];
  std::vector<int> surfaceByChunk_;
  std::vector<PlannedJob> jobs_;
};

} // namespace

std::vector<PlannedJob> planJobs(const ShotLayout& shot, const ShotState& state) {
  Planner planner(shot, state);
  planner.planChain(Stage::Bake, nullptr, false);
  const Stage bake = Stage::Bake;
  if (shot.whitewater) planner.planChain(Stage::Whitewater, &bake, shot.whitewaterNeedsWholeBake);
  planner.planArrays(Stage::Surface);
  if (shot.render) planner.planArrays(Stage::Render);
  return planner.take();
}

std::string dependencyText(const std::vector<Dependency>& after, const std::vector<std::string>& ids) {
  std::string ok, corresponding;
  for (const Dependency& d : after) {
    const std::string id = d.planned >= 0 ? ids.at(std::size_t(d.planned)) : d.live;
    (d.kind == Dependency::AfterOk ? ok : corresponding) += ":" + id;
  }
  std::string text;
  if (!ok.empty()) text = "afterok" + ok;
  if (!corresponding.empty()) text += (text.empty() ? "" : ",") + std::string("aftercorr") + corresponding;
  return text;
}

} // namespace cascade::farm
