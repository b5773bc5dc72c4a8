// The farm's job graph (FarmPlan.h), its scripts (JobScript.h) and its record
// (FarmRecord.h), without a cluster: exact job sets and dependencies for a fresh
// shot, a resumed one, and shots with jobs still queued.
#include "farm/FarmPlan.h"
#include "farm/FarmRecord.h"
#include "farm/FarmStatus.h"
#include "farm/JobScript.h"
#include "libsph/Errors.h"

#include <gtest/gtest.h>

using namespace cascade;
using namespace cascade::farm;

namespace {

ShotLayout shot25() {
  ShotLayout shot;
  shot.frameCount = 25;
  shot.chunk = 10;
  shot.taskFrames = 3;
  return shot;
}

/// Every frame of every stage the shot has: not done, nothing queued.
ShotState nothingDone(const ShotLayout& shot) {
  ShotState state;
  for (Stage stage : kStages)
    if (shot.has(stage)) state[stage].assign(std::size_t(shot.frameCount), FrameState{});
  return state;
}

void setDone(ShotState& state, Stage stage, int first, int last) {
  for (int f = first; f <= last; ++f) state[stage][std::size_t(f - 1)].done = true;
}

/// The job ids a plan's jobs would get, "j0", "j1", ...
std::vector<std::string> ids(const std::vector<PlannedJob>& plan) {
  std::vector<std::string> names;
  for (std::size_t k = 0; k < plan.size(); ++k) names.push_back("j" + std::to_string(k));
  return names;
}

std::string describe(const std::vector<PlannedJob>& plan) {
  std::string text;
  const std::vector<std::string> names = ids(plan);
  for (std::size_t k = 0; k < plan.size(); ++k) {
    const PlannedJob& job = plan[k];
    text += names[k] + "=" + stageName(job.stage) + " " + std::to_string(job.first) + "-" + std::to_string(job.last);
    if (!job.tasks.empty()) {
      text += " [";
      for (std::size_t t = 0; t < job.tasks.size(); ++t) text += (t ? "," : "") + std::to_string(job.tasks[t]);
      text += "]";
    }
    const std::string after = dependencyText(job.after, names);
    if (!after.empty()) text += " " + after;
    text += "\n";
  }
  return text;
}

} // namespace

TEST(ShotLayout, ChunksAndTasksTileTheFrames) {
  const ShotLayout shot = shot25();
  EXPECT_EQ(shot.chunkCount(), 3);
  EXPECT_EQ(shot.chunkLast(2), 25);
  // Tasks start at the chunk's first frame, every taskFrames, and stop at its end.
  EXPECT_EQ(shot.taskFirst(1), 1);
  EXPECT_EQ(shot.taskFirst(9), 7);
  EXPECT_EQ(shot.taskFirst(10), 10);
  EXPECT_EQ(shot.taskLast(10), 10);
  EXPECT_EQ(shot.taskFirst(13), 11);
  EXPECT_EQ(shot.taskFirst(14), 14);
  EXPECT_EQ(shot.taskIndex(14), 1);
  EXPECT_EQ(shot.taskLast(24), 25);
}

TEST(FarmPlan, AFreshShotChainsTheBakeAndPipelinesTheRest) {
  const ShotLayout shot = shot25();
  const std::vector<PlannedJob> plan = planJobs(shot, nothingDone(shot));
  EXPECT_EQ(describe(plan), "j0=bake 1-10\n"
                            "j1=bake 11-20 afterok:j0\n"
                            "j2=bake 21-25 afterok:j1\n"
                            "j3=surface 1-10 [1,4,7,10] afterok:j0\n"
                            "j4=surface 11-20 [11,14,17,20] afterok:j1\n"
                            "j5=surface 21-25 [21,24] afterok:j2\n"
                            "j6=render 1-10 [1,4,7,10] aftercorr:j3\n"
                            "j7=render 11-20 [11,14,17,20] aftercorr:j4\n"
                            "j8=render 21-25 [21,24] aftercorr:j5\n");
}

TEST(FarmPlan, WhitewaterIsASecondChainAndTheFoamGridWaitsForIt) {
  ShotLayout shot = shot25();
  shot.chunk = 15;
  shot.taskFrames = 15;
  shot.whitewater = true;
  shot.surfaceReadsWhitewater = true;
  EXPECT_EQ(describe(planJobs(shot, nothingDone(shot))), "j0=bake 1-15\n"
                                                         "j1=bake 16-25 afterok:j0\n"
                                                         "j2=whitewater 1-15 afterok:j0\n"
                                                         "j3=whitewater 16-25 afterok:j2:j0:j1\n"
                                                         "j4=surface 1-15 [1] afterok:j0:j2\n"
                                                         "j5=surface 16-25 [16] afterok:j1:j3\n"
                                                         "j6=render 1-15 [1] afterok:j2,aftercorr:j4\n"
                                                         "j7=render 16-25 [16] afterok:j3,aftercorr:j5\n");
}

TEST(FarmPlan, AutomaticWhitewaterLimitsWaitForTheWholeBake) {
  // The limits come from the whole bake's statistics: a chunk made before the
  // last bake chunk would clamp with other limits than a local run.
  ShotLayout shot = shot25();
  shot.taskFrames = 10;
  shot.whitewater = true;
  shot.whitewaterNeedsWholeBake = true;
  EXPECT_EQ(describe(planJobs(shot, nothingDone(shot))), "j0=bake 1-10\n"
                                                         "j1=bake 11-20 afterok:j0\n"
                                                         "j2=bake 21-25 afterok:j1\n"
                                                         "j3=whitewater 1-10 afterok:j0:j1:j2\n"
                                                         "j4=whitewater 11-20 afterok:j3:j0:j1:j2\n"
                                                         "j5=whitewater 21-25 afterok:j4:j1:j2\n"
                                                         "j6=surface 1-10 [1] afterok:j0\n"
                                                         "j7=surface 11-20 [11] afterok:j1\n"
                                                         "j8=surface 21-25 [21] afterok:j2\n"
                                                         "j9=render 1-10 [1] afterok:j3,aftercorr:j6\n"
                                                         "j10=render 11-20 [11] afterok:j4,aftercorr:j7\n"
                                                         "j11=render 21-25 [21] afterok:j5,aftercorr:j8\n");
}

TEST(FarmPlan, AResumeSubmitsOnlyWhatIsMissing) {
  const ShotLayout shot = shot25();
  ShotState state = nothingDone(shot);
  for (Stage stage : kStages)
    if (shot.has(stage)) setDone(state, stage, 1, 25);
  EXPECT_TRUE(planJobs(shot, state).empty());
  // A killed render task left frames 8 and 9 (of its task 7-9): one task, waiting for nothing.
  state[Stage::Render][7].done = state[Stage::Render][8].done = false;
  EXPECT_EQ(describe(planJobs(shot, state)), "j0=render 1-10 [7]\n");
}

TEST(FarmPlan, AFailedBakeChunkIsBakedAgainWithEverythingAfterIt) {
  const ShotLayout shot = shot25();
  ShotState state = nothingDone(shot);
  setDone(state, Stage::Bake, 1, 10);
  setDone(state, Stage::Surface, 1, 10);
  setDone(state, Stage::Render, 1, 9);
  EXPECT_EQ(describe(planJobs(shot, state)), "j0=bake 11-20\n"
                                             "j1=bake 21-25 afterok:j0\n"
                                             "j2=surface 11-20 [11,14,17,20] afterok:j0\n"
                                             "j3=surface 21-25 [21,24] afterok:j1\n"
                                             "j4=render 1-10 [10]\n"
                                             "j5=render 11-20 [11,14,17,20] aftercorr:j2\n"
                                             "j6=render 21-25 [21,24] aftercorr:j3\n");
}

TEST(FarmPlan, WorkStillQueuedIsNotSubmittedAgainButWaitedFor) {
  const ShotLayout shot = shot25();
  ShotState state = nothingDone(shot);
  setDone(state, Stage::Bake, 1, 20);
  for (int f = 21; f <= 25; ++f) state[Stage::Bake][std::size_t(f - 1)].liveJob = "42";
  setDone(state, Stage::Surface, 1, 20);
  setDone(state, Stage::Render, 1, 20);
  // The surface of frames 24-25 is queued as task 43_1; frames 21-23 were cancelled.
  state[Stage::Surface][23].liveJob = state[Stage::Surface][24].liveJob = "43_1";
  state[Stage::Render][23].liveJob = state[Stage::Render][24].liveJob = "44_1";
  EXPECT_EQ(describe(planJobs(shot, state)), "j0=surface 21-25 [21] afterok:42\n"
                                             "j1=render 21-25 [21] aftercorr:j0\n");
}

TEST(FarmPlan, ARenderTaskWhoseSurfaceIsQueuedWaitsForThatTask) {
  const ShotLayout shot = shot25();
  ShotState state = nothingDone(shot);
  setDone(state, Stage::Bake, 1, 25);
  setDone(state, Stage::Surface, 1, 25);
  setDone(state, Stage::Render, 1, 25);
  state[Stage::Surface][0].done = false;
  state[Stage::Surface][0].liveJob = "7_0";
  state[Stage::Render][0].done = state[Stage::Render][1].done = false;
  EXPECT_EQ(describe(planJobs(shot, state)), "j0=render 1-10 [1] afterok:7_0\n");
}

TEST(JobScript, ArraysNameTheirTasksCompactlyAndEveryJobChecksOut) {
  FarmRecord record;
  record.scene = "pool";
  record.token = "0123abcd";
  record.cascade = "/opt/cascade/bin/cascade";
  record.out = "/shots/it's here";
  record.shot = shot25();
  record.options.partition = "gpu";
  record.options.bakeTime = "02:00:00";
  record.options.sbatch = {"--qos=high"};
  record.options.setup = {"module load cascade"};
  PlannedJob surface{Stage::Surface, 1, 11, 20, {11, 14, 17, 20}, {}};
  const std::string text = jobScript(record, 2, surface);
  EXPECT_NE(text.find("#SBATCH --array=0-3\n"), std::string::npos) << text;
  EXPECT_NE(text.find("#SBATCH --partition=gpu\n"), std::string::npos);
  EXPECT_EQ(text.find("#SBATCH --time="), std::string::npos) << "the bake's limit is not the tasks'";
  EXPECT_NE(text.find("#SBATCH --qos=high\n"), std::string::npos);
  EXPECT_NE(text.find("#SBATCH --kill-on-invalid-dep=yes\n"), std::string::npos);
  EXPECT_NE(text.find("OUT='/shots/it'\\''s here'\n"), std::string::npos) << text;
  EXPECT_NE(text.find("module load cascade\n"), std::string::npos);
  EXPECT_NE(text.find("!= '0123abcd' ]"), std::string::npos);
  EXPECT_NE(text.find("FIRST=$(( 11 + SLURM_ARRAY_TASK_ID * 3 ))"), std::string::npos) << text;
  EXPECT_NE(text.find("if [ \"$LAST\" -gt 20 ]; then LAST=20; fi"), std::string::npos);
  EXPECT_EQ(scriptName(2, surface), "farm/jobs/round-2/surface.0011-0020.sh");
  // Irregular ids: a list, runs of three or more with a step.
  surface.tasks = {11, 17, 20};
  EXPECT_NE(jobScript(record, 2, surface).find("#SBATCH --array=0,2,3\n"), std::string::npos);
  ShotLayout wide = record.shot;
  wide.chunk = 100;
  wide.frameCount = 100;
  wide.taskFrames = 1;
  record.shot = wide;
  PlannedJob render{Stage::Render, 0, 1, 100, {1, 3, 5, 7, 8, 20}, {}};
  EXPECT_NE(jobScript(record, 1, render).find("#SBATCH --array=0-6:2,7,19\n"), std::string::npos)
      << jobScript(record, 1, render);
  PlannedJob bake{Stage::Bake, 0, 1, 100, {}, {}};
  const std::string bakeText = jobScript(record, 1, bake);
  EXPECT_NE(bakeText.find("#SBATCH --time=02:00:00\n"), std::string::npos);
  EXPECT_NE(bakeText.find("exec \"$CASCADE\" bake \"$OUT/scene.json\" -o \"$OUT\" --frames 1-100\n"), std::string::npos);
}

TEST(FarmRecord, RoundTripsThroughJsonAndFindsTheLatestJobOfAFrame) {
  FarmRecord record;
  record.scene = "pool";
  record.token = "t";
  record.cascade = "/c";
  record.out = "/o";
  record.shot = shot25();
  record.hashes = {"b", "", "s", "r"};
  record.options.setup = {"a", "b"};
  Round first{1, "submit", "2026-11-26T00:00:00Z", {}, "9"};
  first.jobs.push_back({Stage::Bake, "1", 1, 10, {}, "farm/jobs/round-1/bake.0001-0010.sh", ""});
  first.jobs.push_back({Stage::Render, "2", 1, 10, {1, 4, 7, 10}, "x.sh", "aftercorr:1"});
  Round second{2, "resume", "2026-11-26T01:00:00Z", {}, "12"};
  second.jobs.push_back({Stage::Render, "11", 1, 10, {7}, "y.sh", ""});
  record.rounds = {first, second};
  const FarmRecord back = fromJson(toJson(record), "farm.json");
  EXPECT_EQ(toJson(back), toJson(record));
  EXPECT_EQ(back.latestJob(Stage::Render, 8)->second, "11_2");  // round 2's task (ids: index in the chunk)
  EXPECT_EQ(back.latestJob(Stage::Render, 4)->second, "2_1");   // round 1's second task
  EXPECT_EQ(back.latestJob(Stage::Bake, 10)->second, "1");
  EXPECT_FALSE(back.latestJob(Stage::Bake, 11).has_value());
  nlohmann::json damaged = toJson(record);
  damaged["rounds"][0]["jobs"][0]["last"] = 99;
  EXPECT_THROW(fromJson(damaged, "farm.json"), InputError);
  EXPECT_THROW(fromJson(nlohmann::json::object(), "farm.json"), InputError);
}

TEST(FarmStatus, RunsOfFramesAreNamedWithTheirJobs) {
  std::vector<FrameStatus> frames(7);
  frames[0].kind = frames[1].kind = FrameStatus::Done;
  frames[2].kind = FrameStatus::Running;
  frames[2].job = "5_0";
  for (int k : {3, 4}) frames[std::size_t(k)] = {FrameStatus::Failed, "5_1", "CANCELLED"};
  frames[5] = {FrameStatus::Failed, "6", "FAILED, exit 3"};
  frames[6].kind = FrameStatus::Missing;
  EXPECT_EQ(statusLine(frames),
            "done 1-2, running 3, failed 4-5 (job 5_1: CANCELLED), failed 6 (job 6: FAILED, exit 3), not submitted 7");
}
