// The whitewater stage over a bake's particle caches.
#include "whitewater/WhitewaterStage.h"

#include "libsph/Errors.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/io/ParticleCache.h"
#include "libsph/scene/Manifest.h"
#include "libsph/scene/SceneJson.h"
#include "libsph/search/UniformGridSearch.h"
#include "whitewater/WhitewaterFile.h"

#include <nlohmann/json.hpp>

#include <malloc.h>

#include <algorithm>
#include <climits>
#include <cstdio>
#include <chrono>
#include <future>
#include <map>
#include <sstream>

namespace cascade::whitewater {

namespace fs = std::filesystem;

namespace {

constexpr int kLimitSampleFrames = 16;

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// Cache file per frame number (.vdb preferred over .ply).
std::map<int, fs::path> cacheFiles(const OutputLayout& layout) {
  std::map<int, fs::path> files;
  for (int frame : listFrames(layout.particlesDir(), "particles", "ply")) files[frame] = layout.particlesPly(frame);
  for (int frame : listFrames(layout.particlesDir(), "particles", "vdb")) files[frame] = layout.particles(frame);
  return files;
}

/// The potentials of cached frames (fluid-fluid neighbours within h), reusing
/// the memory of the frame before (page faults on fresh allocations otherwise
/// cost as much as the neighbour search).
class FramePotentials {
public:
  /// `energyFloor`: as computePotentials() (-1: every particle's).
  const FluidPotentials& of(const ParticleFrame& frame, Real h, const std::string& label, float energyFloor = -1) {
    fluidArrays(frame, mX, mV, label);
    mGrid.findNeighbors(mX.data(), mX.size(), h, mNeighbors);
    computePotentials(mX, mV, mNeighbors, h, mPotentials, energyFloor);
    return mPotentials;
  }
  /// The positions of the last frame given to of().
  const std::vector<Vec3r>& positions() const { return mX; }

private:
  std::vector<Vec3r> mX, mV;
  search::UniformGridSearch mGrid;
  NeighborLists mNeighbors;
  FluidPotentials mPotentials;
};

nlohmann::json limitsToJson(const PotentialLimits& limits) {
  return {{"trapped_air", limits.trappedAir}, {"wave_crest", limits.waveCrest},
          {"kinetic_energy", limits.kineticEnergy}};
}

RemovalBox fluidBoundsGrown(const ParticleFrame& frame) {
  RemovalBox box;
  if (frame.size() == 0) return box;
  Vec3r low = frame.position[0], high = frame.position[0];
  for (const Vec3r& x : frame.position) {
    low = low.cwiseMin(x);
    high = high.cwiseMax(x);
  }
  const Real grow = std::max((high - low).maxCoeff(), Real(frame.spacing > 0 ? frame.spacing : 0.01));
  box.min = low - Vec3r::Constant(grow);
  box.max = high + Vec3r::Constant(grow);
  return box;
}

} // namespace

void keepFreedMemory() {
  ::mallopt(M_MMAP_MAX, 0);
  ::mallopt(M_TRIM_THRESHOLD, INT_MAX);
}

double spacingRateFactor(const scene::WhitewaterSettings& settings, double spacing) {
  if (settings.ratesPer == "particle") return 1.0;
  const double ratio = spacing / settings.referenceSpacing;
  return ratio * ratio * (settings.ratesPer == "volume" ? ratio : 1.0);
}

double birthRateScale(const scene::WhitewaterSettings& settings, double spacing) {
  return settings.rateScale * spacingRateFactor(settings, spacing);
}

std::string whitewaterHash(const WhitewaterStageOptions& options, const std::string& bakeHash) {
  nlohmann::json inputs{{"settings", scene::whitewaterSettingsToJson(options.settings)},
                        {"spacing", options.spacing},
                        {"gravity", {options.gravity.x(), options.gravity.y(), options.gravity.z()}},
                        {"bake", bakeHash}};
  if (options.domain)
    inputs["domain"] = {options.domain->min.x(), options.domain->min.y(), options.domain->min.z(),
                        options.domain->max.x(), options.domain->max.y(), options.domain->max.z()};
  const std::string text = inputs.dump();
  return scene::hexHash(scene::fnv1a(text.data(), text.size()));
}

WhitewaterRunReport runWhitewater(const OutputLayout& layout, const WhitewaterStageOptions& options,
                                  const std::function<void(const WhitewaterFrameReport&)>& progress,
                                  const std::function<void(const std::string&)>& log) {
  const auto say = [&](const std::string& line) {
    if (log) log(line);
  };
  const std::map<int, fs::path> caches = cacheFiles(layout);
  const FrameRange& range = options.frames;
  std::vector<int> wanted;
  for (const auto& [frame, path] : caches)
    if (range.contains(frame)) wanted.push_back(frame);
  if (caches.empty() || wanted.empty())
    throw InputError(layout.particlesDir().string() +
                     ": no particle caches (particles.NNNN.vdb or .ply) in the frame range");
  if (range.last && *range.last > caches.rbegin()->first)
    throw InputError("--frames: the caches end at frame " + std::to_string(caches.rbegin()->first) + " (asked for " +
                     std::to_string(*range.last) + ")");
  const int firstFrame = caches.begin()->first, lastFrame = wanted.back();
  for (int frame = firstFrame; frame <= lastFrame; ++frame)
    if (!caches.count(frame))
      throw InputError(layout.particles(frame).string() +
                       ": missing (whitewater needs every cached frame from the first, " +
                       std::to_string(firstFrame) + ", on)");

  const auto readCache = [&](int frame) { return readParticleFrame(caches.at(frame)); };
  ParticleFrame firstCache = readCache(firstFrame);
  if (firstCache.velocity.size() != firstCache.size())
    throw InputError(caches.at(firstFrame).string() + ": the particle cache has no velocities (whitewater needs them)");
  const double spacing = options.spacing > 0 ? options.spacing : double(firstCache.spacing);
  if (!(spacing > 0))
    throw InputError(caches.at(firstFrame).string() + ": the cache does not say its particle spacing (give --spacing)");
  const auto bakeHashIt = firstCache.metadata.find("bake_hash");
  WhitewaterRunReport report;
  const std::string settingsHash =
      whitewaterHash(options, bakeHashIt == firstCache.metadata.end() ? "" : bakeHashIt->second);
  const double fps = options.fps > 0 ? options.fps : 30.0;
  const auto frameTime = [&](const ParticleFrame& cache, int frame) {
    return cache.time > 0 ? cache.time : frame / fps;
  };

  if (options.settings.ratesPer != "particle") {
    const bool volume = options.settings.ratesPer == "volume";
    char line[240];
    std::snprintf(line, sizeof line, "whitewater: rates per %s: x %.6g (spacing %.6g m against the reference %.6g m, %s)",
                  volume ? "volume of water" : "area of water surface",
                  spacingRateFactor(options.settings, spacing), spacing,
                  options.settings.referenceSpacing, volume ? "cubed" : "squared");
    say(line);
  }
  WhitewaterSolver solver(options.settings, options.gravity, spacing,
                          options.domain ? *options.domain : fluidBoundsGrown(firstCache));
  const Real h = Real(solver.supportRadius());

  // Limits: as set, or from the bake's statistics (kept in limits.json).
  const scene::WhitewaterSettings& settings = options.settings;
  PotentialLimits limits;
  limits.trappedAir = settings.trappedAir;
  limits.waveCrest = settings.waveCrest;
  limits.kineticEnergy = settings.kineticEnergy;
  fs::create_directories(layout.whitewaterDir());
  if (settings.limits == "auto") {
    const fs::path limitsFile = layout.whitewaterDir() / "limits.json";
    const nlohmann::json cachedFrames = {firstFrame, caches.rbegin()->first, caches.size()};
    bool have = false;
    std::error_code error;
    if (fs::is_regular_file(limitsFile, error)) {
      try {
        const nlohmann::json kept = nlohmann::json::parse(readTextFile(limitsFile));
        if (kept.at("input_hash") == settingsHash && kept.at("cached_frames") == cachedFrames) {
          limits.trappedAir = kept.at("trapped_air").get<std::array<double, 2>>();
          limits.waveCrest = kept.at("wave_crest").get<std::array<double, 2>>();
          limits.kineticEnergy = kept.at("kinetic_energy").get<std::array<double, 2>>();
          have = true;
        }
      } catch (const std::exception&) {
        have = false;  // unreadable: make it again
      }
    }
    if (!have) {
      std::vector<int> all;
      for (const auto& [frame, path] : caches) all.push_back(frame);
      const std::size_t samples = std::min<std::size_t>(kLimitSampleFrames, all.size());
      std::vector<FluidPotentials> potentials;
      FramePotentials sampler;
      for (std::size_t k = 0; k < samples; ++k) {
        const int frame = all[(all.size() - 1) * k / std::max<std::size_t>(1, samples - 1)];
        const FluidPotentials& sample = sampler.of(readCache(frame), h, caches.at(frame).string());
        potentials.push_back({sample.trappedAir, sample.waveCrest, sample.kineticEnergy, {}});
      }
      limits = limitsFromStatistics(potentials, physicalFloors(h, options.gravity.norm()));
      nlohmann::json kept = limitsToJson(limits);
      kept["input_hash"] = settingsHash;
      kept["cached_frames"] = cachedFrames;  // first, last, count
      kept["frames_sampled"] = samples;
      writeTextAtomically(limitsFile, kept.dump(2) + "\n");
    }
    report.limitsFromStatistics = true;
    report.limitsFromPartialBake = options.bakeLastFrame && caches.rbegin()->first < *options.bakeLastFrame;
  }
  report.limits = limits;
  // The frames' hash: the stage's inputs and the limits they were made with.
  report.inputHash = settingsHash;
  if (report.limitsFromStatistics) {
    const std::string chained = settingsHash + limitsToJson(limits).dump();
    report.inputHash = scene::hexHash(scene::fnv1a(chained.data(), chained.size()));
  }
  if (report.limitsFromPartialBake)
    say("whitewater: the bake is not finished (caches up to frame " + std::to_string(caches.rbegin()->first) +
        " of " + std::to_string(*options.bakeLastFrame) +
        "): automatic limits from the frames there are; a run after the bake makes them again and remakes the "
        "frames made now");
  {
    std::ostringstream line;
    line << "whitewater: limits (" << (report.limitsFromStatistics ? "from the bake's statistics" : "fixed")
         << "): trapped air [" << limits.trappedAir[0] << ", " << limits.trappedAir[1] << "], wave crest ["
         << limits.waveCrest[0] << ", " << limits.waveCrest[1] << "], kinetic energy [" << limits.kineticEnergy[0]
         << ", " << limits.kineticEnergy[1] << "] J/kg";
    say(line.str());
  }

  // A frame's file is good when it reads and was made from these inputs.
  const auto good = [&](int frame) {
    std::error_code error;
    if (!fs::is_regular_file(layout.whitewater(frame), error)) return false;
    if (options.force && range.contains(frame)) return false;
    try {
      return readWhitewaterHeader(layout.whitewater(frame)).inputHash == report.inputHash &&
             (!settings.ply || fs::is_regular_file(layout.whitewaterPly(frame), error));
    } catch (const InputError&) {
      return false;
    }
  };
  // Start after the latest good frame before the range, else at the first frame.
  int start = firstFrame;
  for (int frame = wanted.front() - 1; frame >= firstFrame; --frame)
    if (good(frame)) {
      start = frame + 1;
      break;
    }

  std::future<void> writing;  // the last frame's files, written behind the next frame
  const auto finishWriting = [&] {
    if (writing.valid()) writing.get();  // rethrows a failed write
  };
  FramePotentials framePotentials;
  FrameBirthRates startField, endField;  // of frames fieldFrame - 1 and fieldFrame
  int fieldFrame = -1;
  FluidInterval interval;
  WhitewaterFrame state;  // at frame stateFrame
  int stateFrame = -1;
  std::optional<ParticleFrame> previousCache;  // the cache of frame - 1
  int previousCacheFrame = -1;
  for (int frame = start; frame <= lastFrame; ++frame) {
    const auto began = std::chrono::steady_clock::now();
    WhitewaterFrameReport frameReport;
    frameReport.frame = frame;
    if (good(frame)) {
      frameReport.skipped = true;
      if (range.contains(frame) && progress) progress(frameReport);
      continue;
    }
    ParticleFrame cache = frame == firstFrame ? firstCache : readCache(frame);
    frameReport.fluid = cache.size();
    WhitewaterFrame next;
    next.spacing = spacing;
    next.inputHash = report.inputHash;
    next.time = frameTime(cache, frame);
    if (frame > firstFrame) {
      if (stateFrame != frame - 1) {
        state = readWhitewaterVdb(layout.whitewater(frame - 1));
        stateFrame = frame - 1;
      }
      if (previousCacheFrame != frame - 1) {
        previousCache = readCache(frame - 1);
        previousCacheFrame = frame - 1;
      }
      const std::string label = caches.at(frame - 1).string();
      const double t0 = frameTime(*previousCache, frame - 1), t1 = next.time;
      if (!(t1 > t0))
        throw InputError(caches.at(frame).string() + ": its time is not after the frame before's");
      const auto potentialStart = std::chrono::steady_clock::now();
      // The birth rates of the interval's two frames (WhitewaterSolver.h); only
      // the particles fast enough to give birth need their sums. The end's are
      // the next interval's start.
      const auto rateFieldOf = [&](const ParticleFrame& frameCache, const std::string& frameLabel,
                                   FrameBirthRates& out) {
        const FluidPotentials& potentials = framePotentials.of(frameCache, h, frameLabel, float(limits.kineticEnergy[0]));
        solver.frameRates(framePotentials.positions(),
                          birthRates(potentials, limits, settings.trappedAirRate, settings.waveCrestRate,
                                     birthRateScale(settings, spacing)),
                          out);
      };
      if (fieldFrame != frame - 1) rateFieldOf(*previousCache, label, endField);
      std::swap(startField, endField);
      rateFieldOf(cache, caches.at(frame).string(), endField);
      fieldFrame = frame;
      frameReport.potentialSeconds = secondsSince(potentialStart);
      interval.assign(*previousCache, cache, t0, t1, label);
      next.particles = std::move(state.particles);
      next.nextId = state.nextId;
      frameReport.stats = solver.advance(interval, startField, endField, frame - 1, next.particles, next.nextId);
    }
    next.type = solver.classify(next.particles, cache.position);
    // The file is the state: the next frame goes on from the positions as the
    // file stores them (exactly what reading it gives, as a resumed run does),
    // while the file is written behind.
    state = next;
    roundPositionsAsStored(state);
    stateFrame = frame;
    finishWriting();
    writing = std::async(std::launch::async, [file = layout.whitewater(frame), plyFile = layout.whitewaterPly(frame),
                                              ply = settings.ply, written = std::move(next)]() mutable {
      writeWhitewaterVdb(file, written);
      if (!ply) return;
      roundPositionsAsStored(written);  // the PLY holds what the VDB gives back
      writeWhitewaterPly(plyFile, written);
    });
    previousCache = std::move(cache);
    previousCacheFrame = frame;
    frameReport.counts = state.counts();
    frameReport.seconds = secondsSince(began);
    if (progress) progress(frameReport);
    report.frames.push_back(frameReport);
  }
  finishWriting();
  return report;
}

} // namespace cascade::whitewater
