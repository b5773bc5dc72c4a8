#include "libsph/scene/Bake.h"

#include "libsph/Errors.h"
#include "libsph/bodies/MovingBoundary.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/io/ParticleCache.h"
#include "libsph/io/TriangleMesh.h"
#include "libsph/probes/Probes.h"
#include "libsph/scene/BakeCheckpoint.h"
#include "libsph/scene/FluidSources.h"
#include "libsph/scene/Manifest.h"
#include "libsph/scene/Progress.h"
#include "libsph/scene/SceneJson.h"
#include "libsph/scene/SceneSetup.h"
#include "libsph/solver/DomainPartition.h"
#include "libsph/solver/Simulation.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <sstream>

namespace cascade::scene {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {
/// The suffixes of a probe's probes.csv columns (one column per suffix, named NAME + suffix).
const std::vector<const char*>& columnSuffixes(const Probe& probe) {
  static const std::vector<const char*> vector{"_x", "_y", "_z"}, body{"_x", "_y", "_z", "_vx", "_vy", "_vz"},
      scalar{""};
  if (probe.type == "force" || probe.type == "velocity") return vector;
  if (probe.type == "body") return body;
  return scalar;
}
} // namespace

std::string probeHeader(const Scene& scene) {
  std::string header = "t";
  for (const Probe& probe : scene.probes)
    for (const char* suffix : columnSuffixes(probe)) header += "," + probe.name + suffix;
  return header + "\n";
}

namespace {

std::string formatValue(double value) {
  if (!std::isfinite(value)) return "nan";
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.9g", value);
  return buffer;
}

/// One probes.csv sample: each column's value after `t`, in the header's order, at the
/// simulation's current state, from `particles` (all of them). NaN where a probe reads
/// nothing (no water under a height probe, no fluid near a velocity probe).
std::vector<double> probeValues(const Scene& scene, const Simulation& simulation, const Particles& particles) {
  std::vector<double> values;
  const Real spacing = Real(scene.fluid.spacing);
  const Vec3r gravity(Real(scene.gravity[0]), Real(scene.gravity[1]), Real(scene.gravity[2]));
  // Point probes find their particles through one grid per sample.
  std::vector<Vec3r> points;
  for (const Probe& probe : scene.probes)
    if (probe.type == "pressure" || probe.type == "velocity")
      points.emplace_back(Real(probe.at[0]), Real(probe.at[1]), Real(probe.at[2]));
  double faceRadius = 0;
  for (const Probe& probe : scene.probes) faceRadius = std::max(faceRadius, probe.radius);
  const NeighborLists near = probeNeighborhoods(particles, points, simulation.supportRadius() + Real(faceRadius));
  std::size_t point = 0;
  const double nan = std::nan("");
  for (const Probe& probe : scene.probes) {
    const Vec3r at(Real(probe.at[0]), Real(probe.at[1]), Real(probe.at[2]));
    if (probe.type == "height") {
      values.push_back(waterHeight(particles.position, probe.at[0], probe.at[1], spacing));
    } else if (probe.type == "pressure") {
      const Vec3r normal(Real(probe.normal[0]), Real(probe.normal[1]), Real(probe.normal[2]));
      values.push_back(pressureOverDisc(particles, at, normal, Real(probe.radius), simulation.supportRadius(), gravity,
                                        near.begin(point), near.end(point)));
      ++point;
    } else if (probe.type == "velocity") {
      Vec3d velocity = Vec3d::Constant(nan);  // no fluid within a support radius
      velocityAt(particles, at, simulation.supportRadius(), near.begin(point), near.end(point), velocity);
      values.insert(values.end(), {velocity.x(), velocity.y(), velocity.z()});
      ++point;
    } else if (probe.type == "body") {
      const long index = simulation.findBoundary(probe.obstacle);
      const MovingBoundary* solid = index >= 0 ? simulation.movingSolid(std::size_t(index)) : nullptr;
      const Vec3d c = solid ? solid->center() : Vec3d::Constant(nan);
      const Vec3d v = solid ? solid->velocity().linear : Vec3d::Constant(nan);
      values.insert(values.end(), {c.x(), c.y(), c.z(), v.x(), v.y(), v.z()});
    } else if (probe.type == "front") {
      const Vec3r direction(Real(probe.direction[0]), Real(probe.direction[1]), Real(probe.direction[2]));
      values.push_back(surgeFront(particles.position, direction.normalized(), spacing));
    } else if (probe.type == "force") {
      const Vec3d force = obstacleForce(simulation, probe.obstacle);
      values.insert(values.end(), {force.x(), force.y(), force.z()});
    }
  }
  return values;
}

/// The probes.csv row of `values` at time t: NaN reads "nan", but a velocity probe
/// with no fluid near leaves its three cells empty.
std::string probeRow(const Scene& scene, double t, const std::vector<double>& values) {
  std::string row = formatValue(t);
  std::size_t column = 0;
  for (const Probe& probe : scene.probes)
    for (std::size_t k = 0; k < columnSuffixes(probe).size(); ++k, ++column)
      row += "," + (probe.type == "velocity" && std::isnan(values[column]) ? std::string() : formatValue(values[column]));
  return row + "\n";
}

/// Values at time t from samples of the same probes at t0 and t1 (t0 <= t <= t1),
/// linear in time; where either reads nothing (NaN), the nearer sample's value.
std::vector<double> interpolateProbes(double t0, const std::vector<double>& v0, double t1, const std::vector<double>& v1,
                                      double t) {
  const double w = t1 > t0 ? std::clamp((t - t0) / (t1 - t0), 0.0, 1.0) : 1.0;
  std::vector<double> out(v1.size());
  for (std::size_t k = 0; k < v1.size(); ++k)
    out[k] = std::isnan(v0[k]) || std::isnan(v1[k]) ? (w < 0.5 ? v0[k] : v1[k]) : v0[k] + w * (v1[k] - v0[k]);
  return out;
}

ParticleFrame frameOf(const Simulation& simulation, const Particles& particles, const Scene& scene, int frame,
                      const std::string& bakeHash) {
  ParticleFrame out;
  out.position = particles.position;
  out.velocity = particles.velocity;
  out.id = particles.id;
  out.density = particles.density;
  out.pressure = particles.pressure;
  out.time = simulation.time();
  out.spacing = Real(scene.fluid.spacing);
  out.metadata["scene"] = scene.name;
  out.metadata["frame"] = std::to_string(frame);
  out.metadata["bake_hash"] = bakeHash;  // later stages chain their input hashes on it
  return out;
}

bool framesExist(const OutputLayout& layout, int first, int last) {
  std::error_code error;
  for (int f = first; f <= last; ++f)
    if (!fs::is_regular_file(layout.particles(f), error)) return false;
  return true;
}

} // namespace

BakeResult bakeScene(const Scene& scene, const BakeOptions& options) {
  const auto wallStart = Clock::now();
  const OutputLayout layout(options.outDir);
  BakeResult result;
  result.frameCount = scene.output.frameCount();
  const std::vector<std::string> meshHashes = meshContentHashes(scene);  // each mesh file read once
  result.inputHash = sceneInputHash(scene, meshHashes);
  const int first = options.frames.first.value_or(1);
  const int last = std::min(options.frames.last.value_or(result.frameCount), result.frameCount);
  if (first > result.frameCount)
    throw InputError("--frames: the scene has " + std::to_string(result.frameCount) + " frames (got " +
                     std::to_string(first) + ")");
  result.firstFrame = first;
  result.lastFrame = last;
  DomainPartition* const partition = options.partition;
  const bool writer = partition == nullptr || partition->rank() == 0;  // rank 0 writes every file
  // Rank 0's writes. Over ranks a failure there is its own (the other ranks are waiting in
  // an exchange): it leaves as a runtime_error, which stops every rank (cascade's main).
  const auto onWriter = [&](auto&& write) {
    if (!writer) return;
    if (partition == nullptr) return write();
    try {
      write();
    } catch (const std::exception& error) {
      throw std::runtime_error(error.what());
    }
  };
  // Over ranks: a count summed over all ranks (on every rank).
  const auto countEverywhere = [&](double local) {
    if (partition) partition->sumOverRanks(&local, 1);
    return local;
  };
  // Refuse, within seconds and before allocating, a bake the machine cannot hold.
  const MemoryEstimate memory = estimateBakeMemory(scene);
  const double available = availableMemory();
  if (!options.ignoreMemory && available > 0 && memory.bytes > available) {
    const auto gib = [](double bytes) {
      std::ostringstream text;
      const double value = bytes / double(1 << 30);
      if (value < 10) text << std::setprecision(2) << value;
      else text << std::fixed << std::setprecision(0) << value;
      return text.str();
    };
    std::ostringstream counts;
    counts << std::setprecision(2) << memory.fluidParticles << " particles, " << memory.boundarySamples
           << " boundary samples at spacing " << scene.fluid.spacing << " m";
    throw InputError("bake: needs about " + gib(memory.bytes) + " GiB (" + counts.str() + "), this machine has " +
                     gib(available) + " GiB available (a coarser fluid.spacing, or --ignore-memory to try anyway)");
  }
  Progress progress(options.log, options.progressTerminal);

  // The resolved scene first: a failed bake still says what it ran.
  onWriter([&] { writeResolvedScene(scene, layout.scene(), meshHashes); });
  const nlohmann::json written = resolvedScene(scene, layout.scene(), meshHashes);
  // The assets, as OUT/scene.json names them (relative to OUT, with their content hash).
  nlohmann::json assets = nlohmann::json::array();
  for (const nlohmann::json& obstacle : written["boundaries"]["obstacles"])
    assets.push_back({{"obstacle", obstacle["name"]}, {"mesh", obstacle["mesh"]}, {"hash", obstacle["mesh_hash"]}});

  const fs::path checkpointFile = checkpointPath(options.outDir);
  const std::optional<BakeCheckpoint> header = readCheckpointHeader(checkpointFile);
  const bool matching = options.resume && header && header->inputHash == result.inputHash;
  if (matching && header->frame >= last && framesExist(layout, first, last)) {
    result.upToDate = true;
    result.lastFrame = last;
    result.complete = header->frame >= result.frameCount && framesExist(layout, 1, result.frameCount);
    progress.message("bake: frames " + std::to_string(first) + "-" + std::to_string(last) +
                     " already baked in " + options.outDir.string());
    return result;
  }

  Simulation simulation(simulationSettings(scene));
  setUpSimulation(scene, simulation, options.log);
  if (partition) {
    simulation.setPartition(partition);
    countEverywhere(0);  // every rank has read the checkpoint's header before rank 0 may remove it
  }

  BakeCheckpoint state;
  state.inputHash = result.inputHash;
  state.emitters.resize(scene.fluid.emitters.size());
  // Resume only if every frame of the requested range before the checkpoint is on disk.
  if (matching && header->frame < last && framesExist(layout, first, std::min(header->frame, last))) {
    state = readCheckpoint(checkpointFile, simulation);
    result.resumedAfter = state.frame;
    progress.message("bake: resuming " + scene.name + " after frame " + std::to_string(state.frame) + " (t=" +
                     formatValue(simulation.time()) + " s)");
  } else if (writer) {
    std::error_code error;
    fs::remove(checkpointFile, error);
    // Stale frames of an earlier bake of another scene.
    for (int f : listFrames(layout.particlesDir(), "particles", "vdb"))
      if (f > result.frameCount) fs::remove(layout.particles(f), error);
  }
  const double wallBefore = state.wallSeconds;

  std::vector<std::vector<Vec3r>> layers;
  for (const Emitter& emitter : scene.fluid.emitters) layers.push_back(emitterLayer(emitter, scene.fluid.spacing));
  const auto add = [&](const Vec3r& position, const Vec3r& velocity) { simulation.addParticle(position, velocity); };
  const auto emit = [&]() {
    for (std::size_t e = 0; e < scene.fluid.emitters.size(); ++e)
      holdInflow(scene.fluid.emitters[e], scene.fluid.spacing, simulation.time(), state.emitters[e],
                 simulation.particles());
    for (std::size_t e = 0; e < scene.fluid.emitters.size(); ++e)
      emitUntil(scene.fluid.emitters[e], layers[e], scene.fluid.spacing, simulation.time(), state.emitters[e], add);
  };
  std::vector<char> leaving;
  const auto kill = [&]() {
    if (scene.boundaries.kill.empty()) return;
    std::size_t killed = 0;
    if (flagLeavingParticles(Boundaries{std::nullopt, {}, {}, {}, std::nullopt, scene.boundaries.kill},
                             simulation.particles(), leaving) > 0)
      killed = simulation.removeParticles(leaving);
    state.killed += std::uint64_t(countEverywhere(double(killed)));
  };
  // Probes never steer the steps (only frames do): a probe time inside a step reads
  // the probes at the step's start and end, interpolated linearly in time, so the
  // probe rate changes probes.csv and nothing else. (Steps shortened to land on probe
  // times changed the water: DFSPH's wall pressure after the Lobovsky impact read
  // 0.55-0.78 rho g H at 1 kHz, 0.75-0.98 at 2 kHz and 1.0 at 100 Hz.)
  const bool hasProbes = !scene.probes.empty();
  const double probeInterval = 1.0 / scene.output.probeRate;
  const auto nextProbeTime = [&] { return double(state.probeSamples) * probeInterval; };
  const auto sampleNow = [&]() {  // collective over ranks: the values on the writer, empty elsewhere
    if (!partition) return probeValues(scene, simulation, simulation.particles());
    const Particles all = simulation.gatheredParticles();
    return writer ? probeValues(scene, simulation, all) : std::vector<double>();
  };
  std::vector<double> stepStartValues;  // at stepStartTime, when the step crosses a probe time
  double stepStartTime = -1;
  std::vector<double> lastValues;  // the last step end's, when sampled (reused as the next step's start)
  double lastTime = -1;
  const auto sampleDue = [&]() {
    if (!hasProbes || nextProbeTime() > simulation.time() + 1e-12) return;
    lastValues = sampleNow();
    lastTime = simulation.time();
    for (; nextProbeTime() <= simulation.time() + 1e-12; ++state.probeSamples) {
      const double t = nextProbeTime();
      const bool inside = stepStartTime >= 0 && t > stepStartTime && t < simulation.time() - 1e-12;
      if (writer)
        state.probeRows += probeRow(
            scene, t, inside ? interpolateProbes(stepStartTime, stepStartValues, lastTime, lastValues, t) : lastValues);
    }
  };
  const auto sampleStepStart = [&]() {  // before a step that crosses a probe time
    stepStartTime = simulation.time();
    stepStartValues = lastTime == stepStartTime ? lastValues : sampleNow();
  };

  if (state.frame == 0) {
    // A fresh start: the solids for the renderer, the first emitted layers, probes at t = 0.
    onWriter([&] { writeObj(layout.root / "geometry" / "solids.obj", simulation.solidsMesh()); });
    emit();
    simulation.nextTimeStep();  // derives densities and constants for the t = 0 probes
    sampleDue();
  } else if (writer && !fs::exists(layout.root / "geometry" / "solids.obj")) {
    onWriter([&] { writeObj(layout.root / "geometry" / "solids.obj", simulation.solidsMesh()); });
  }

  {
    // SEED 2.2: type I boundary particles per solid (the mesh loader logged its triangles),
    // each with its ratio to area / gap^2 (1 for a wall's lattice; see docs/boundary-sampling.md).
    simulation.nextTimeStep();  // started: boundaries sampled
    const BoundaryParticles& samples = simulation.boundaryParticles();
    const std::vector<std::size_t> counts = samples.samplesPerBoundary(simulation.boundaryCount());
    const double gap = double(samples.sampleGap());
    std::ostringstream line;
    line << "bake: " << std::uint64_t(countEverywhere(double(simulation.particles().size()))) << " fluid particles; type I boundary particles (gap "
         << std::setprecision(3) << gap * 1000 << " mm; count / (area / gap^2)):";
    for (std::size_t b = 0; b < counts.size(); ++b) {
      const double area = surfaceArea(simulation.boundary(b).surfaceMesh());
      line << (b ? ", " : " ") << simulation.boundary(b).name() << " " << counts[b];
      if (area > 0 && gap > 0) line << " (" << std::fixed << std::setprecision(2) << double(counts[b]) * gap * gap / area << "x)";
      line << std::defaultfloat;
    }
    progress.message(line.str());
    if (scene.solver.type == "wcsph" && scene.solver.kernels == "auto" &&
        simulation.settings().solver.kernels == KernelPair::CubicSpline)
      progress.message("bake: WCSPH kernels cubic_spline (solver.kernels \"auto\": a rigid body floats)");
  }
  const std::uint64_t stepsBefore = simulation.stepCount();
  // Not collective: `particles` is the count over all ranks.
  const auto recordBake = [&](bool done, const std::string& error, double particles) {
    if (!writer) return;
    nlohmann::json record;
    record["done"] = done;
    record["input_hash"] = result.inputHash;
    record["assets"] = assets;
    record["frames"] = {first, result.lastFrame};
    record["frame_count"] = result.frameCount;
    record["seconds"] = wallBefore + std::chrono::duration<double>(Clock::now() - wallStart).count();
    record["simulated_time"] = simulation.time();
    record["steps"] = simulation.stepCount();
    record["particles"] = std::uint64_t(particles);
    record["boundary_particles"] = simulation.boundaryParticleCount();
    record["removed"] = simulation.removedCount() + state.killed;
    record["resumed_after"] = result.resumedAfter;
    // Solver phases of this run (ms), Simulation::timings().
    const StepTimings& t = simulation.timings();
    record["phase_ms"] = {{"neighbors", t.neighbors}, {"density", t.density}, {"forces", t.forces},
                          {"boundary", t.boundary}, {"integrate", t.integrate}};
    if (!error.empty()) record["error"] = error;
    onWriter([&] { recordStage(layout.manifest(), scene.name, "bake", record); });
  };

  try {
    for (int frame = state.frame + 1; frame <= last; ++frame) {
      const double frameTime = double(frame) / scene.output.fps;
      while (simulation.time() < frameTime) {
        // Exact resume needs no fresh search per step: the grid's incremental
        // rebuild keeps the canonical order of a full one (UniformGridSearch.h),
        // so a restored run (which starts with a full build) sees the same lists.
        const double dt = simulation.nextTimeStep();
        stepStartTime = -1;
        if (hasProbes && simulation.time() + dt >= nextProbeTime() - 1e-12) sampleStepStart();
        if (simulation.time() + dt >= frameTime) simulation.advanceTo(frameTime);
        else simulation.step();
        emit();
        kill();
        sampleDue();
        // Over ranks, one reduction: the particle count, and whether any rank was asked to stop.
        double shared[2] = {double(simulation.particles().size()),
                            options.stopFlag && *options.stopFlag ? 1.0 : 0.0};
        if (partition) partition->sumOverRanks(shared, 2);
        progress.update(frame, last, simulation.time(), double(last) / scene.output.fps, simulation.stepCount(),
                        std::size_t(shared[0]));
        if (shared[1] > 0) {
          result.interrupted = true;
          break;
        }
      }
      if (result.interrupted) break;
      if (frame >= first) {
        Particles gathered;  // over ranks: all ranks' particles on rank 0
        if (partition) gathered = simulation.gatheredParticles();
        const Particles& all = partition ? gathered : simulation.particles();
        onWriter([&] {
          writeParticleFrame(layout.particles(frame), frameOf(simulation, all, scene, frame, result.inputHash));
          // Moving solids: the solids at this frame for the renderer (geometry/solids.NNNN.obj).
          if (simulation.hasMovingSolids()) writeObj(layout.solids(frame), simulation.solidsMesh());
        });
        ++result.framesWritten;
      }
      if (hasProbes) onWriter([&] { writeTextAtomically(layout.probes(), probeHeader(scene) + state.probeRows); });
      state.frame = frame;
      state.wallSeconds = wallBefore + std::chrono::duration<double>(Clock::now() - wallStart).count();
      if (writer) {
        onWriter([&] { writeCheckpoint(checkpointFile, state, simulation); });
      } else {
        std::ostringstream unused;
        simulation.save(unused);  // the other ranks' part of rank 0's gather
      }
      result.lastFrame = frame;
    }
  } catch (const InstabilityError& error) {
    // Every rank stops here together (Simulation agrees on the message).
    progress.message("");
    result.lastFrame = state.frame;
    recordBake(false, error.what(), countEverywhere(double(simulation.particles().size())));
    throw;
  }

  result.lastFrame = state.frame;
  result.simulatedTime = simulation.time();
  result.wallSeconds = std::chrono::duration<double>(Clock::now() - wallStart).count();
  result.steps = simulation.stepCount() - stepsBefore;
  result.particles = std::size_t(countEverywhere(double(simulation.particles().size())));
  result.removed = simulation.removedCount() + state.killed;
  result.complete = !result.interrupted && state.frame >= result.frameCount && framesExist(layout, 1, result.frameCount);
  recordBake(result.complete, result.interrupted ? "interrupted" : "", double(result.particles));
  char summary[256];
  std::snprintf(summary, sizeof summary,
                "bake: %s frames %d-%d (%d written) t=%.3f s, %llu steps in %.1f s (%.3g simulated s per wall s), "
                "%zu particles, %llu removed",
                result.interrupted ? "interrupted after" : "baked", first, result.lastFrame, result.framesWritten,
                result.simulatedTime, static_cast<unsigned long long>(result.steps), result.wallSeconds,
                result.wallSeconds > 0 ? (result.simulatedTime - double(result.resumedAfter) / scene.output.fps) /
                                             result.wallSeconds
                                       : 0.0,
                result.particles, static_cast<unsigned long long>(result.removed));
  std::string line = summary;
  if (const std::uint64_t keptOut = simulation.keptOutCount(); keptOut > 0)
    line += ", " + std::to_string(keptOut) + " put back out of solids (steps that carried them in)";
  progress.finish(line);
  return result;
}

} // namespace cascade::scene
