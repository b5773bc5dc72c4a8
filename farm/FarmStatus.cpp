#include "farm/FarmStatus.h"

#include "libsph/io/OutputLayout.h"

#include <filesystem>
#include <set>

namespace cascade::farm {

namespace fs = std::filesystem;

const char* kindName(FrameStatus::Kind kind) {
  switch (kind) {
  case FrameStatus::Done: return "done";
  case FrameStatus::Running: return "running";
  case FrameStatus::Pending: return "pending";
  case FrameStatus::Failed: return "failed";
  case FrameStatus::Missing: return "not submitted";
  case FrameStatus::Unknown: return "unknown";
  }
  return "?";
}

bool ShotStatus::complete(Stage stage) const {
  for (const FrameStatus& f : (*this)[stage])
    if (f.kind != FrameStatus::Done) return false;
  return true;
}

bool frameDone(const FarmRecord& record, Stage stage, int frame) {
  const OutputLayout layout(record.out);
  std::error_code error;
  const auto exists = [&](const fs::path& path) { return fs::is_regular_file(path, error); };
  switch (stage) {
  case Stage::Bake: return exists(layout.particles(frame));
  case Stage::Whitewater:
    return exists(layout.whitewater(frame)) && (!record.whitewaterPly || exists(layout.whitewaterPly(frame)));
  case Stage::Surface:
    return (record.surfaceOutputs == "vdb" || exists(layout.mesh(frame, record.meshFormat))) &&
           (record.surfaceOutputs == "mesh" || exists(layout.surface(frame)));
  case Stage::Render: return exists(layout.render(frame));
  }
  return false;
}

std::vector<std::string> recordedJobIds(const FarmRecord& record) {
  std::set<std::string> ids;
  for (const Round& round : record.rounds)
    for (const RecordedJob& job : round.jobs) ids.insert(job.id);
  return {ids.begin(), ids.end()};
}

ShotStatus shotStatus(const FarmRecord& record, const std::map<std::string, JobState>& jobs, bool answered,
                      const std::string& schedulerError) {
  ShotStatus status;
  status.schedulerAnswered = answered;
  status.schedulerError = schedulerError;
  for (Stage stage : kStages) {
    if (!record.shot.has(stage)) continue;
    std::vector<FrameStatus>& frames = status.frames[int(stage)];
    frames.resize(std::size_t(record.shot.frameCount));
    for (int f = 1; f <= record.shot.frameCount; ++f) {
      FrameStatus& s = frames[std::size_t(f - 1)];
      if (frameDone(record, stage, f)) {
        s.kind = FrameStatus::Done;
        continue;
      }
      const auto latest = record.latestJob(stage, f);
      if (!latest) {
        s.kind = FrameStatus::Missing;
        continue;
      }
      s.job = latest->second;
      if (!answered) {
        s.kind = FrameStatus::Unknown;
        continue;
      }
      const auto found = jobs.find(s.job);
      if (found == jobs.end()) {
        s.kind = FrameStatus::Failed;
        s.detail = "ended; Slurm no longer knows it";
        continue;
      }
      const JobState& job = found->second;
      if (job.live()) {
        s.kind = job.state == "RUNNING" || job.state == "COMPLETING" || job.state == "CONFIGURING"
                     ? FrameStatus::Running
                     : FrameStatus::Pending;
        continue;
      }
      s.kind = FrameStatus::Failed;
      s.detail = job.state;
      if (job.state == "FAILED" || job.exitCode != 0) s.detail += ", exit " + std::to_string(job.exitCode);
      if (!job.reason.empty() && job.reason != "None" && job.reason != "NonZeroExitCode")
        s.detail += " (" + job.reason + ")";
    }
  }
  return status;
}

ShotState planningState(const FarmRecord& record, const ShotStatus& status) {
  ShotState state;
  for (Stage stage : kStages) {
    if (!record.shot.has(stage)) continue;
    for (const FrameStatus& f : status[stage]) {
      FrameState s;
      s.done = f.kind == FrameStatus::Done;
      if (f.live()) s.liveJob = f.job;
      state[stage].push_back(s);
    }
  }
  return state;
}

std::string statusLine(const std::vector<FrameStatus>& frames) {
  std::string line;
  std::size_t k = 0;
  while (k < frames.size()) {
    // A run of frames in the same state (and, when failed, the same job and reason).
    std::size_t end = k;
    while (end + 1 < frames.size() && frames[end + 1].kind == frames[k].kind &&
           (frames[k].kind != FrameStatus::Failed ||
            (frames[end + 1].job == frames[k].job && frames[end + 1].detail == frames[k].detail)))
      ++end;
    if (!line.empty()) line += ", ";
    line += kindName(frames[k].kind);
    line += " " + std::to_string(k + 1);
    if (end > k) line += "-" + std::to_string(end + 1);
    if (frames[k].kind == FrameStatus::Failed) line += " (job " + frames[k].job + ": " + frames[k].detail + ")";
    k = end + 1;
  }
  return line;
}

nlohmann::json statusJson(const FarmRecord& record, const ShotStatus& status) {
  nlohmann::json stages = nlohmann::json::object();
  for (Stage stage : kStages) {
    if (!record.shot.has(stage)) continue;
    nlohmann::json entry = {{"done", nlohmann::json::array()},    {"running", nlohmann::json::array()},
                            {"pending", nlohmann::json::array()}, {"failed", nlohmann::json::array()},
                            {"not_submitted", nlohmann::json::array()}, {"unknown", nlohmann::json::array()},
                            {"failed_jobs", nlohmann::json::object()}};
    const std::vector<FrameStatus>& frames = status[stage];
    for (std::size_t k = 0; k < frames.size(); ++k) {
      const FrameStatus& f = frames[k];
      const char* key = f.kind == FrameStatus::Missing ? "not_submitted" : kindName(f.kind);
      entry[key].push_back(int(k + 1));
      if (f.kind == FrameStatus::Failed) entry["failed_jobs"][f.job] = f.detail;
    }
    stages[stageName(stage)] = entry;
  }
  return {{"out", record.out},
          {"scene", record.scene},
          {"frame_count", record.shot.frameCount},
          {"scheduler_answered", status.schedulerAnswered},
          {"stages", stages}};
}

} // namespace cascade::farm
